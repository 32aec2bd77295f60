#include "core/export/obj_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "core/brdf/ggx_equivalent.h"
#include "core/export/export_input.h"
#include "core/scene/names.h"

namespace mvbrdf::exporter {
namespace {

// Ns of the MTL; MODEL_Ns.png holds ke / kNsScale.
constexpr double kNsScale = 10000.0;

absl::Status WritePng(const std::filesystem::path& file, const cv::Mat& image) {
  if (!cv::imwrite(file.string(), image)) {
    return absl::UnavailableError(absl::StrCat(file.string(), ": could not be written"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ObjExportSummary> ExportObj(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                           const std::filesystem::path& out, int frame) {
  if (out.extension() != ".obj") {
    return absl::InvalidArgumentError(absl::StrCat("--out: expected a file ending in .obj, got \"", out.string(), "\""));
  }
  MVBRDF_ASSIGN_OR_RETURN(const ExportInput in, ReadExportInput(run_dir, sequence, frame));
  const pipeline::RunAtlases& a = in.atlases;
  const int rows = a.kd.rows, cols = a.kd.cols;

  // Per texel the thesis's lobe (ks, ke per channel).
  std::vector<std::array<glm::dvec2, 3>> phong(static_cast<size_t>(rows * cols));
  std::vector<double> kd_observed, ks_observed;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = static_cast<size_t>(y * cols + x);
      const brdf::Model model = a.ModelAt(x, y);
      const cv::Vec3f p1 = a.p1.at<cv::Vec3f>(y, x), p2 = a.p2.at<cv::Vec3f>(y, x), kd = a.kd.at<cv::Vec3f>(y, x);
      const cv::Vec3f p3 = a.p3.empty() ? cv::Vec3f::all(0.0f) : a.p3.at<cv::Vec3f>(y, x);
      double ks_top = 0.0;
      for (int c = 0; c < 3; ++c) {
        // The third parameter (GGX's F90 / F0) does not move the head-on peak
        // PhongEquivalent matches, but is passed as the run has it.
        const brdf::ParameterVector p = brdf::PhongEquivalent(model, {p1[c], p2[c], p3[c]});
        phong[i][c] = {std::isfinite(p[0]) ? p[0] : 0.0, p[1]};
        ks_top = std::max(ks_top, phong[i][c].x);
      }
      if (a.confidence.at<float>(y, x) > 0.0f) {
        kd_observed.push_back(std::max({kd[0], kd[1], kd[2]}));
        ks_observed.push_back(ks_top);
      }
    }
  }
  ObjExportSummary summary;
  summary.scale = 1.0 / std::max({Quantile(kd_observed, 0.999), Quantile(ks_observed, 0.999), 1e-12});
  cv::Mat kd_map(rows, cols, CV_8UC3), ks_map(rows, cols, CV_8UC3), ns_map(rows, cols, CV_16UC1);
  size_t clipped = 0;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = static_cast<size_t>(y * cols + x);
      const cv::Vec3f kd = a.kd.at<cv::Vec3f>(y, x);
      cv::Vec3b kd8, ks8;
      bool clip = false;
      double ke = 0.0;
      for (int c = 0; c < 3; ++c) {
        const double d = std::max(0.0f, kd[c]) * summary.scale, s = phong[i][c].x * summary.scale;
        clip |= d > 1.0 || s > 1.0;
        kd8[2 - c] = Srgb8(d);
        ks8[2 - c] = Srgb8(s);
        ke += phong[i][c].y / 3.0;  // MTL's Ns is one exponent
      }
      if (clip && a.confidence.at<float>(y, x) > 0.0f) ++clipped;
      kd_map.at<cv::Vec3b>(y, x) = kd8;
      ks_map.at<cv::Vec3b>(y, x) = ks8;
      ns_map.at<uint16_t>(y, x) = static_cast<uint16_t>(std::lround(65535.0 * std::clamp(ke / kNsScale, 0.0, 1.0)));
    }
  }
  summary.clipped_fraction =
      kd_observed.empty() ? 0.0 : static_cast<double>(clipped) / static_cast<double>(kd_observed.size());

  const std::filesystem::path dir = out.parent_path();
  const std::string stem = out.stem().string();
  const std::string mtl = stem + ".mtl", kd_png = stem + "_Kd.png", ks_png = stem + "_Ks.png", ns_png = stem + "_Ns.png";
  std::string obj = absl::StrCat("# mvbrdf export of ", scene::ShownName(run_dir.string()), " (", frame < 0 ? "rest pose" : "frame ",
                                 frame < 0 ? "" : std::to_string(frame), ")\nmtllib ", mtl, "\no reconstruction\n");
  for (const glm::vec3& v : in.vertices) absl::StrAppendFormat(&obj, "v %.9g %.9g %.9g\n", v.x, v.y, v.z);
  // OBJ's v runs up the image, as the atlas's does (row 0 = v 1).
  for (const glm::vec2& uv : in.atlas.topology.uvs) absl::StrAppendFormat(&obj, "vt %.9g %.9g\n", uv.x, uv.y);
  for (const glm::vec3& n : in.normals) absl::StrAppendFormat(&obj, "vn %.7g %.7g %.7g\n", n.x, n.y, n.z);
  absl::StrAppend(&obj, "usemtl reconstruction\ns 1\n");
  for (const glm::uvec3& t : in.atlas.topology.triangles) {
    absl::StrAppendFormat(&obj, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", t.x + 1, t.x + 1, t.x + 1, t.y + 1, t.y + 1, t.y + 1,
                          t.z + 1, t.z + 1, t.z + 1);
  }
  const std::string material = absl::StrFormat(
      "# mvbrdf: classic Phong, L = I (Kd n.l + Ks (R.v)^Ns), the thesis's model (run brdf: %s; other models'\n"
      "# lobes as the same head-on peak and width, core/brdf/ggx_equivalent.h). Maps: Kd and Ks sRGB, Ns = %g x\n"
      "# the 16-bit Ns map. Scale %.9g: Kd and Ks are the run's x scale (lights x 1 / scale give its radiance).\n"
      "newmtl reconstruction\nKa 0 0 0\nKd 1 1 1\nKs 1 1 1\nNs %g\nillum 2\nmap_Kd %s\nmap_Ks %s\nmap_Ns %s\n",
      in.run.brdf().empty() ? "phong" : in.run.brdf(), kNsScale, summary.scale, kNsScale, kd_png, ks_png, ns_png);
  MVBRDF_RETURN_IF_ERROR(WriteStringToFile(out, obj));
  MVBRDF_RETURN_IF_ERROR(WriteStringToFile(dir / mtl, material));
  MVBRDF_RETURN_IF_ERROR(WritePng(dir / kd_png, kd_map));
  MVBRDF_RETURN_IF_ERROR(WritePng(dir / ks_png, ks_map));
  MVBRDF_RETURN_IF_ERROR(WritePng(dir / ns_png, ns_map));
  summary.vertices = static_cast<int>(in.vertices.size());
  summary.triangles = static_cast<int>(in.atlas.topology.triangles.size());
  summary.files = {out, dir / mtl, dir / kd_png, dir / ks_png, dir / ns_png};
  return summary;
}

}  // namespace mvbrdf::exporter
