#include "core/report/report_page.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/report/html.h"
#include "core/report/svg_plot.h"

namespace mvbrdf::report {
namespace {

std::string F(double v, const char* format = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

std::string Rgb(const google::protobuf::RepeatedField<double>& v, const char* format = "%.3f") {
  std::vector<std::string> parts;
  for (double x : v) parts.push_back(F(x, format));
  return absl::StrJoin(parts, " / ");
}

constexpr char kStyle[] = R"css(
body { font: 14px/1.45 system-ui, sans-serif; margin: 24px auto; max-width: 1180px; color: #222; }
h1 { font-size: 24px; margin-bottom: 4px; } h2 { font-size: 19px; margin-top: 34px; border-bottom: 1px solid #ddd; }
.summary { color: #555; } .warning { background: #fff4d6; padding: 6px 10px; border-left: 4px solid #f0a000; }
table { border-collapse: collapse; margin: 10px 0; } th, td { padding: 3px 9px; border-bottom: 1px solid #e4e4e4; text-align: right; }
th { background: #f4f4f4; } table.text td, table.text th { text-align: left; } td:first-child, th:first-child { text-align: left; } tr.chosen td { font-weight: 600; background: #eef6ee; }
.plot text { font: 12px system-ui, sans-serif; fill: #333; } .plot .plot-title { font-weight: 600; font-size: 13px; }
.plot .value { fill: #555; font-size: 11px; }
.figures { display: flex; flex-wrap: wrap; gap: 14px; } figure { margin: 0; } figcaption { color: #555; font-size: 12px; }
figure img { image-rendering: pixelated; border: 1px solid #ddd; max-width: 100%; }
.relit { display: grid; grid-template-columns: repeat(6, 1fr); gap: 6px; } .relit img { width: 100%; }
.ok { color: #197a19; } .bad { color: #b3261e; } code { background: #f4f4f4; padding: 0 3px; }
)css";

// Marks the page as loaded without script errors and with its plots drawn;
// the browser test reads these attributes.
constexpr char kCheckScript[] = R"js(
window.addEventListener('error', function (e) {
  document.body.setAttribute('data-report-errors', String(e.message || e));
});
window.addEventListener('load', function () {
  var plots = document.querySelectorAll('svg.plot');
  var drawn = 0;
  plots.forEach(function (p) { var b = p.getBBox(); if (b.width > 0 && b.height > 0) drawn++; });
  var images = document.querySelectorAll('img');
  var loaded = 0;
  images.forEach(function (i) { if (i.complete && i.naturalWidth > 0) loaded++; });
  document.body.setAttribute('data-plots', plots.length + '/' + drawn);
  document.body.setAttribute('data-images', images.length + '/' + loaded);
  document.body.setAttribute('data-report-ready', 'yes');
});
)js";

// Tooltips: the definitions of docs/glossary.md, shortened (title attributes
// and <abbr>, escaped like every other text).
namespace term {
constexpr char kEa[] =
    "E_a (thesis Eq. 6.7): mean squared error over all Samples of the fit of one Phong BRDF for the whole model, "
    "averaged over R, G, B (linear units). Lower is better.";
constexpr char kEd[] =
    "E_d (thesis Eq. 6.8): mean over triangles of each triangle's mean squared error when it has its own kd, averaged "
    "over R, G, B (linear units). With --sweep-criterion e-d the configuration with the lowest E_d is chosen (ties "
    "by E_a).";
constexpr char kHeldOut[] =
    "Held-out error (issue #14): each triangle's kd and one specular lobe fitted on one block of frames, the mean "
    "squared error measured on the other block (and the other way round); the median over triangles, averaged over "
    "R, G, B (linear units). The configuration with the lowest held-out error is chosen (the default criterion).";
constexpr char kTable61[] =
    "Table 6.1 of the thesis: every candidate light configuration with its lit triangles, E_a and E_d, and the "
    "held-out error; the configuration is chosen by the run's criterion (see the rule).";
constexpr char kTable62[] =
    "Table 6.2 of the thesis: one Phong BRDF per cluster, fitted by Levenberg-Marquardt and by Powell's method.";
constexpr char kTable71[] =
    "Table 7.1 of the thesis: per camera, the mean squared error between the resampled input and the rendering with "
    "the BRDF atlases, and with the per-frame correction atlases added to kd.";
constexpr char kConfiguration[] =
    "Light configuration: a named set of the scene's lights assumed on together (scene lightConfigurations).";
constexpr char kLitTriangles[] = "Triangles lit by at least one light of the configuration in the Samples used.";
constexpr char kMargin[] =
    "Configuration margin: how much higher the second-best error (by the run's criterion: held-out error or E_d) is "
    "than the chosen one's, relative; small means the choice is uncertain.";
constexpr char kKd[] = "kd: diffuse albedo per colour channel, linear, in the scene's intensity units.";
constexpr char kKs[] = "ks: specular coefficient per colour channel (extended Phong, mirror lobe).";
constexpr char kKe[] =
    "ke: specular exponent of the mirror lobe (higher: a sharper highlight; a Blinn-Phong exponent is about 4x).";
constexpr char kModelChoice[] =
    "--brdf auto: each cluster fits every model of core/brdf to its Samples but those of the last camera and every "
    "fourth frame, and takes the one with the lowest error on those (another model must beat Phong by more than "
    "2 %).";
constexpr char kRelighting[] =
    "The reconstruction and the truth drawn by the same renderer from views between the capture's cameras under "
    "lights the capture did not use, one at a time; RMSE in linear radiance over pixels showing observed texels, "
    "relative: over the truth's RMS.";
constexpr char kF0[] =
    "F0 (--brdf ggx): specular reflectance at normal incidence per colour channel (glTF's metallic-roughness model; "
    "0.04 for most dielectrics), in the scene's units.";
constexpr char kRoughness[] =
    "roughness (--brdf ggx): glTF's perceptual roughness in [0.02, 1]; higher: a broader highlight. After it "
    "F90/F0, the Fresnel curve's rise from normal incidence to grazing (25: a dielectric of index 1.5; 1: a "
    "metal's flat curve), and the grazing support: the most grazing geometry the capture saw the lobe in (its "
    "visibility term's denominator), below which the renderer does not extrapolate the lobe (absent: none, the "
    "plain lobe is drawn).";
constexpr char kSamples[] =
    "Samples: one observation of a surface point: its radiance in one camera and frame with the light and view "
    "cosines (per triangle for the light sweep, per texel for the fits).";
constexpr char kCluster[] =
    "Cluster: texels grouped by albedo (k-means) into one material, which gets one BRDF fit; seeded by the scene's "
    "materialSeeds or with k chosen automatically.";
constexpr char kClusterFlags[] =
    "Flags: why a cluster's numbers are not a trusted material: tiny (too few texels, < 0.5 % of the seen ones or "
    "< 16: merged into the nearest cluster), no_samples (no data: merged), ks_ke_not_identifiable, at_bound, ...";
constexpr char kCost[] = "The solver's final cost: half the sum of squared residuals over the cluster's Samples.";
constexpr char kMse[] = "Mean squared error of the fit over its Samples, linear units.";
constexpr char kMseBrdf[] = "MSE between the resampled input and the rendering with the BRDF atlases (kd, ks, ke).";
constexpr char kMseCorrection[] =
    "MSE with each frame's correction atlas added to kd (kd + c): what the fixed BRDF cannot explain.";
constexpr char kObservations[] = "Texel observations compared: texels visible in this camera, summed over frames.";
constexpr char kKdRmse[] =
    "kd RMSE: root mean squared difference from the true kd over the texels seen at least 10 times.";
constexpr char kClusterAccuracy[] = "Share of the texels whose cluster's majority material is their true material.";
constexpr char kRefused[] =
    "Masked: outside the camera's video.maskPath; saturated: a channel at or above video.saturationLevel. Neither "
    "becomes an observation.";
constexpr char kPlan[] =
    "The plan: the stages this run needs and why; a skipped stage names its reason (e.g. one configuration: no "
    "sweep).";
constexpr char kRelit[] =
    "The reconstruction rendered from the first camera under one point light moving around the model on the "
    "camera's side.";
constexpr char kCalibration[] =
    "Calibration (issue #14): each camera's pose (optionally focal length and k1) refined from the video before the "
    "Samples are gathered, and the chosen configuration's lights refined after the sweep; changes against the "
    "scene's values with the solver's 1-sigma.";
constexpr char kCentreChange[] = "In the scene's world units.";
constexpr char kReprojectionChange[] =
    "Mean image displacement (pixels) of the visible surface points between the scene's camera and the refined one.";
constexpr char kResidual[] = "Root mean squared photometric residual (linear) at the scene's calibration → refined.";
constexpr char kReprojectionError[] =
    "Mean image distance (pixels) between the true camera's and this camera's projections of the mesh's frame-0 "
    "vertices that the true camera sees.";
constexpr char kLightIntensity[] =
    "Light intensities are only known up to one common scale (a brighter light and a darker kd look the same).";
}  // namespace term

std::string Figure(const ReportImage& image, int width = 0) {
  return "<figure>" + PngImg(image.png, image.caption, width) + "<figcaption>" + Escape(image.caption) +
         "</figcaption></figure>";
}

std::string TradeoffSection(const v1::TradeoffReport& tradeoff) {
  std::map<std::string, int> group_of;
  std::vector<std::string> groups;
  std::vector<ScatterPoint> kd_points, ks_points;
  std::vector<std::vector<std::string>> rows;
  for (const v1::TradeoffPoint& p : tradeoff.points()) {
    auto it = group_of.find(p.knob());
    if (it == group_of.end()) {
      it = group_of.emplace(p.knob(), static_cast<int>(groups.size())).first;
      groups.push_back(p.knob());
    }
    const std::string label = p.chosen() ? "defaults" : p.setting();
    kd_points.push_back({p.seconds(), p.kd_rmse(), label, it->second, p.chosen()});
    ks_points.push_back({p.seconds(), p.ks_rel_error(), label, it->second, p.chosen()});
    rows.push_back({p.knob(), p.setting(), F(p.seconds(), "%.1f"), F(p.kd_rmse(), "%.4f"), F(p.ks_rel_error(), "%.3f"),
                    F(p.ke_rel_error(), "%.3f"), p.configuration_correct() ? "yes" : "no",
                    F(p.peak_rss_bytes() / 1048576.0, "%.0f")});
  }
  std::string out = "<section id=\"tradeoff\"><h2>Error against run time</h2>";
  out += "<p>Each point is a measured run of <code>" + Escape(tradeoff.scene()) +
         "</code> with one knob changed from the defaults (ringed). The dashed line is the Pareto front: no run is both "
         "faster and more accurate than a point on it.</p>";
  out += ParetoSvg("kd RMSE against run time", "run time (s)", "kd RMSE (linear)", kd_points, groups);
  out += ParetoSvg("ks relative error against run time", "run time (s)", "ks relative error (mean over clusters)",
                   ks_points, groups);
  out += Table({"knob", "setting", "seconds", "kd RMSE", "ks rel. error", "ke rel. error", "configuration right",
                "peak MiB"},
               rows);
  return out + "</section>";
}

// Every cluster with its texels and flags; one that is not a material
// ("tiny", "no_samples": its texels joined the nearest cluster) is marked.
// "a → b" of two figures.
std::string BeforeAfter(double before, double after, const char* format = "%.4g") {
  return F(before, format) + " → " + F(after, format);
}

std::string Vec3(const google::protobuf::RepeatedField<double>& v, const char* format = "%.4g") {
  return v.size() == 3 ? "(" + Rgb(v, format) + ")" : "—";
}

// Issue #14: what was refined (cameras before pass 1, lights after the
// sweep), by how much, with the solver's 1-sigma, or why not; against the
// truth when the evaluation has it. Every text from the run is escaped.
std::string CalibrationSection(const v1::RunReport& run, const std::optional<v1::EvaluationReport>& evaluation) {
  const v1::CalibrationReport& c = run.calibration();
  std::string out = "<section id=\"calibration\"><h2>" + Abbr("Calibration", term::kCalibration) + "</h2>";
  const std::string mode = c.cameras_mode().empty() ? "" : " (--refine-cameras " + Escape(c.cameras_mode()) + ")";
  if (c.cameras_refined()) {
    out += "<p id=\"calibration-cameras\">Cameras refined" + mode + " on " + absl::StrCat(c.frames_used()) +
           " frames in " + F(c.cameras_seconds(), "%.1f") + " s: " + Escape(c.cameras_decision()) + "</p>";
  } else {
    out += "<p id=\"calibration-cameras\">Cameras not refined" + mode + ": " + Escape(c.cameras_decision()) + "</p>";
  }
  bool measured = false;
  for (const v1::CameraRefinementRow& r : c.cameras()) measured = measured || r.observations() > 0;
  if (measured) {
    std::vector<std::vector<std::string>> rows;
    for (const v1::CameraRefinementRow& r : c.cameras()) {
      rows.push_back({r.name(), F(r.rotation_change_deg(), "%.4f") + " ± " + F(r.rotation_sigma_deg(), "%.2g"),
                      F(r.centre_change(), "%.4g") + " ± " + F(r.centre_sigma(), "%.2g"),
                      F(100.0 * r.focal_change(), "%.3f"), F(r.k1_change(), "%.4f"),
                      F(r.reprojection_change_px(), "%.3f"), BeforeAfter(r.residual_before(), r.residual_after()),
                      absl::StrCat(r.observations())});
    }
    out += Table({"camera", "rotation change (°)", "centre change", "focal change (%)", "k1 change",
                  "reprojection change (px)", "residual", "observations"},
                 rows, "", {"", "", term::kCentreChange, "", "", term::kReprojectionChange, term::kResidual});
    if (!c.cameras_refined()) out += "<p>(measured, not used)</p>";
  }
  if (!c.lights_mode().empty() || !c.lights_decision().empty() || c.lights_size() > 0) {
    const std::string lmode = c.lights_mode().empty() ? "" : " (--refine-lights " + Escape(c.lights_mode()) + ")";
    out += std::string("<p id=\"calibration-lights\">Lights ") + (c.lights_refined() ? "refined" : "not refined") +
           lmode + (c.lights_refined() ? " in " + F(c.lights_seconds(), "%.1f") + " s: " : ": ") +
           Escape(c.lights_decision()) + "</p>";
    std::vector<std::vector<std::string>> rows;
    for (const v1::LightRefinementRow& r : c.lights()) {
      const bool point = r.position_before_size() == 3;
      rows.push_back({r.name(), point ? F(r.position_change(), "%.4g") + " ± " + F(r.position_sigma(), "%.2g") : "—",
                      point ? "—" : F(r.direction_change_deg(), "%.3f") + " ± " + F(r.direction_sigma_deg(), "%.2g"),
                      Vec3(r.intensity_before()) + " → " + Vec3(r.intensity_after()),
                      "± " + F(100.0 * r.intensity_rel_sigma(), "%.2g") + " %"});
    }
    if (!rows.empty()) {
      out += Table({"light", "position change", "direction change (°)", "intensity (RGB)", "intensity 1-sigma"}, rows,
                   "", {"", term::kCentreChange, "", term::kLightIntensity});
    }
  }
  if (evaluation.has_value() && evaluation->cameras_size() > 0) {
    std::vector<std::vector<std::string>> rows;
    for (const v1::CameraTruthRow& r : evaluation->cameras()) {
      rows.push_back({r.name(), BeforeAfter(r.rotation_error_deg_before(), r.rotation_error_deg_after(), "%.4f"),
                      BeforeAfter(r.centre_error_before(), r.centre_error_after()),
                      BeforeAfter(r.reprojection_error_px_before(), r.reprojection_error_px_after(), "%.3f")});
    }
    out += "<p>Against the truth (the scene's calibration → the cameras as used):</p>";
    out += Table({"camera", "rotation error (°)", "centre error", "reprojection error (px)"}, rows, "",
                 {"", "", "", term::kReprojectionError});
  }
  if (evaluation.has_value() && evaluation->lights_size() > 0) {
    std::vector<std::vector<std::string>> rows;
    for (const v1::LightTruthRow& r : evaluation->lights()) {
      rows.push_back({r.name(), BeforeAfter(r.position_error_before(), r.position_error_after()),
                      BeforeAfter(r.direction_error_deg_before(), r.direction_error_deg_after(), "%.3f"),
                      BeforeAfter(r.intensity_rel_error_before(), r.intensity_rel_error_after(), "%.3f")});
    }
    out +=
        "<p>Lights against the truth (the scene's → as used; intensities after the one common scale, which the "
        "data cannot tell from kd's):</p>";
    out += Table({"light", "position error", "direction error (°)", "intensity rel. error"}, rows, "",
                 {"", "", "", term::kLightIntensity});
  }
  return out + "</section>";
}

std::string ClustersTable(const v1::RunReport& run) {
  if (run.clusters_size() == 0) return "";
  std::vector<std::vector<std::string>> rows;
  // The model's two parameters (issue #15): ks, ke, or GGX's f0, roughness;
  // with --brdf auto each cluster's own model, named in its cells.
  const bool per_cluster = run.brdf() == "auto";
  const bool ggx = run.brdf() == "ggx";
  for (const v1::ClusterRow& c : run.clusters()) {
    const std::string flags = absl::StrJoin(c.flags(), ", ");
    const bool row_ggx = per_cluster ? c.brdf() == "ggx" : ggx;
    std::string p0 = Rgb(row_ggx ? c.f0() : c.ks());
    std::string p1 = Rgb(row_ggx ? c.roughness() : c.ke(), row_ggx ? "%.3f" : "%.1f");
    // GGX's third parameter beside its roughness: F90 / F0 (25 a dielectric).
    if (row_ggx && c.f90_ratio_size() > 0) p1 += "; F90/F0 " + Rgb(c.f90_ratio(), "%.1f");
    // And the grazing support it is drawn within (0: none, the plain lobe).
    if (row_ggx && c.ggx_grazing_support() > 0.0) p1 += "; grazing support " + F(c.ggx_grazing_support(), "%.3f");
    std::vector<std::string> row = {c.name(), absl::StrCat(c.texels()), Rgb(c.centre())};
    if (per_cluster) {
      row.push_back(c.brdf().empty() ? "-" : c.brdf());
      p0 = (row_ggx ? "f0 " : "ks ") + p0;
      p1 = (row_ggx ? "roughness " : "ke ") + p1;
    }
    row.insert(row.end(), {p0, p1, flags.empty() ? "-" : flags});
    rows.push_back(row);
  }
  if (per_cluster) {
    std::string out = "<h3 id=\"clusters\">Clusters</h3><p>Reflectance model: auto (" +
                      Abbr("per cluster", term::kModelChoice) + ").</p>" +
                      Table({"cluster", "texels", "centre (linear RGB)", "model", "first parameter (RGB)",
                             "second parameter (RGB)", "flags"},
                            rows, "", {term::kCluster, "", term::kKd, "", "", "", term::kClusterFlags});
    // Models x clusters: each model's error on the held-out Samples, its fit
    // time, and the pick with its reason.
    std::vector<std::vector<std::string>> choices;
    std::vector<std::string> header = {"cluster"};
    for (const v1::ClusterRow& c : run.clusters()) {
      if (c.model_choices_size() == 0) continue;
      std::vector<std::string> row = {c.name()};
      for (const v1::ModelChoice& m : c.model_choices()) {
        if (choices.empty()) header.push_back(m.model() + " held-out RMSE (fit s)");
        row.push_back(std::isfinite(m.held_out_rmse())
                          ? F(m.held_out_rmse(), "%.5f") + " (" + F(m.seconds(), "%.2f") + ")"
                          : "no fit");
      }
      row.push_back(c.brdf());
      row.push_back(c.brdf_reason());
      choices.push_back(row);
    }
    header.push_back("chosen");
    header.push_back("why");
    if (!choices.empty()) out += "<p id=\"models\">Models × clusters:</p>" + Table(header, choices, "", {});
    return out;
  }
  const std::string model = run.brdf().empty() ? "phong" : run.brdf();
  return "<h3 id=\"clusters\">Clusters</h3><p>Reflectance model: " + Escape(model) + ".</p>" +
         Table({"cluster", "texels", "centre (linear RGB)", ggx ? "f0 (RGB)" : "ks (RGB)",
                ggx ? "roughness (RGB)" : "ke (RGB)", "flags"},
               rows, "",
               {term::kCluster, "", term::kKd, ggx ? term::kF0 : term::kKs, ggx ? term::kRoughness : term::kKe,
                term::kClusterFlags});
}

}  // namespace

std::string BuildReportHtml(const ReportInputs& in) {
  const v1::RunReport& run = in.run;
  std::string h = "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>mvbrdf report: " +
                  Escape(run.scene()) + "</title><style>" + kStyle + "</style><script>" + kCheckScript +
                  "</script></head><body>";
  h += "<h1>BRDF reconstruction</h1><p class=\"summary\"><code>" + Escape(run.scene()) + "</code> — " +
       absl::StrCat(run.frames()) + " frames, " + absl::StrCat(run.cameras_size()) + " cameras in " +
       Abbr("Table 7.1", term::kTable71) + ", " + "atlas " + absl::StrCat(run.atlas().size()) + "², " +
       F(run.seconds(), "%.1f") + " s, peak memory " + F(run.peak_rss_bytes() / 1048576.0, "%.0f") + " MiB; " +
       Escape(run.gl_renderer()) + "</p>";
  h +=
      "<p>" + Abbr("Light configuration", term::kConfiguration) + ": <b>" + Escape(run.chosen_configuration()) + "</b>";
  if (run.light_configurations_size() > 1) {
    const bool held_out = run.configuration_criterion() == "held-out";
    h += " (the next best " + (held_out ? Abbr("held-out error", term::kHeldOut) : Abbr("E_d", term::kEd)) + " is " +
         Abbr(F(100.0 * run.configuration_margin(), "%.1f") + " % higher", term::kMargin) + ")";
  }
  h += ". Rule: " + Escape(run.configuration_rule()) + ".</p>";
  if (!run.configuration_warning().empty()) h += "<p class=\"warning\">" + Escape(run.configuration_warning()) + "</p>";
  for (const std::string& w : run.warnings()) h += "<p class=\"warning\">warning: " + Escape(w) + "</p>";
  h += "<p id=\"refused\">" + Abbr("Refused texel observations", term::kRefused) + ": " +
       absl::StrCat(run.masked_observations()) + " outside a camera's mask, " +
       absl::StrCat(run.saturated_observations()) + " saturated.</p>";

  if (in.evaluation.has_value()) {
    const v1::EvaluationReport& e = *in.evaluation;
    h += "<section id=\"truth\"><h2>Against the ground truth</h2><p>Configuration " +
         std::string(e.configuration_correct() ? "<b class=\"ok\">right</b>" : "<b class=\"bad\">wrong</b>") +
         " (truth: " + Escape(e.true_configuration()) + "); kd RMSE " + F(e.kd_rmse(), "%.4f") + " over " +
         absl::StrCat(e.kd_texels()) + " texels seen ≥ 10 times (median " + F(e.kd_median_abs_error(), "%.4f") +
         ", p95 " + F(e.kd_p95_abs_error(), "%.4f") + "); " + Abbr("cluster accuracy", term::kClusterAccuracy) + " " +
         F(e.cluster_accuracy(), "%.3f") + ".</p>";
    std::vector<std::vector<std::string>> rows;
    for (const v1::MaterialComparison& c : e.clusters()) {
      // ks and ke hold the model's two parameters; "-" where the truth's
      // model is another (only kd is compared).
      const bool compared = c.parameters_compared() || c.brdf().empty();
      const char* second = c.brdf() == "ggx" ? "%.3f" : "%.1f";
      rows.push_back({c.cluster(), c.material(), F(c.kd_rmse(), "%.4f"), compared ? Rgb(c.ks()) : "-",
                      compared ? Rgb(c.ks_true()) : "-", compared ? F(c.ks_rel_error(), "%.3f") : "-",
                      compared ? Rgb(c.ke(), second) : "-", compared ? Rgb(c.ke_true(), second) : "-",
                      compared ? F(c.ke_rel_error(), "%.3f") : "-"});
    }
    h += Table(
        {"cluster", "true material", "kd RMSE", "ks", "ks true", "ks rel. error", "ke", "ke true", "ke rel. error"},
        rows, "", {term::kCluster, "", term::kKdRmse, term::kKs, "", "", term::kKe});
    if (e.has_relighting()) {
      const v1::RelightingEvaluation& r = e.relighting();
      h += "<p id=\"relighting\">" + Abbr("Relighting error", term::kRelighting) + " (" +
           absl::StrCat(r.rows_size()) + " held-out views × lights, frame " + absl::StrCat(r.frame()) +
           "): RMSE " + F(r.rmse(), "%.5f") + ", relative " + F(r.relative_rmse(), "%.3f") + ".</p>";
      std::vector<std::vector<std::string>> relit;
      for (const v1::RelightingMaterialRow& m : r.materials()) {
        relit.push_back({m.material(), m.truth_brdf(), absl::StrCat(m.pixels()), F(m.rmse(), "%.5f"),
                         F(m.relative_rmse(), "%.3f")});
      }
      h += Table({"true material", "truth", "pixels", "relighting RMSE", "relative"}, relit, "", {});
    }
    h += "</section>";
  }

  if (run.has_calibration()) h += CalibrationSection(run, in.evaluation);

  if (in.tradeoff.has_value() && in.tradeoff->points_size() > 0) h += TradeoffSection(*in.tradeoff);

  // The plan and where the time goes.
  h += "<section id=\"plan\"><h2>" + Abbr("Plan", term::kPlan) + ", time and memory</h2>";
  std::vector<std::vector<std::string>> plan_rows;
  for (const v1::PlannedStage& s : run.plan().stages()) plan_rows.push_back({s.name(), "runs", s.why()});
  for (const v1::SkippedStage& s : run.plan().skipped()) plan_rows.push_back({s.name(), "skipped", s.reason()});
  h += Table({"stage", "", "why"}, plan_rows, "text");
  std::vector<std::string> stage_names;
  BarSeries seconds{"seconds", {}, "#3366cc"}, memory{"peak memory", {}, "#ff9900"};
  for (const v1::StageRow& s : run.stages()) {
    stage_names.push_back(s.name());
    seconds.values.push_back(s.seconds());
    memory.values.push_back(s.peak_rss_bytes() / 1048576.0);
  }
  h += BarChartSvg("Time per stage", stage_names, {seconds}, "s");
  h += BarChartSvg("Process peak memory after each stage", stage_names, {memory}, "MiB");
  h += "</section>";

  // Table 6.1.
  if (run.light_configurations_size() > 0) {
    h += "<section id=\"table61\"><h2>" + Abbr("Table 6.1", term::kTable61) + ": light configurations</h2>";
    std::string rows_html = "<table><thead><tr><th title=\"" + Escape(term::kConfiguration) +
                            "\">configuration</th><th title=\"" + Escape(term::kLitTriangles) +
                            "\">lit triangles</th><th title=\"" + Escape(term::kEa) + "\">E_a</th><th title=\"" +
                            Escape(term::kEd) + "\">E_d</th><th title=\"" + Escape(term::kHeldOut) +
                            "\">held-out</th><th>seconds</th></tr></thead><tbody>";
    std::vector<std::string> names;
    BarSeries e_d{"E_d", {}, "#109618"};
    for (const v1::LightConfigurationRow& r : run.light_configurations()) {
      const bool chosen = r.name() == run.chosen_configuration();
      rows_html += std::string(chosen ? "<tr class=\"chosen\">" : "<tr>") + "<td>" + Escape(r.name()) +
                   (chosen ? " ◀" : "") + "</td><td>" + absl::StrCat(r.lit_triangles()) + "</td><td>" +
                   F(r.e_a(), "%.6f") + "</td><td>" + F(r.e_d(), "%.6f") + "</td><td>" + F(r.e_held_out(), "%.6f") +
                   "</td><td>" + F(r.seconds(), "%.2f") + "</td></tr>";
      names.push_back(r.name());
      e_d.values.push_back(r.e_d());
    }
    h += rows_html + "</tbody></table>";
    h += BarChartSvg("E_d per configuration (lower is better)", names, {e_d}, "");
    h += "</section>";
  }

  // Table 6.2.
  if (run.solvers_size() > 0) {
    h += "<section id=\"table62\"><h2>" + Abbr("Table 6.2", term::kTable62) + ": one BRDF per cluster</h2>";
    std::vector<std::vector<std::string>> rows;
    for (const v1::SolverRow& s : run.solvers()) {
      rows.push_back({s.cluster(), s.solver(), Rgb(s.kd()), Rgb(s.ks()), Rgb(s.ke(), "%.1f"), F(s.final_cost(), "%.6g"),
                      F(s.mse(), "%.3g"), absl::StrCat(s.samples()), F(s.seconds(), "%.3f"),
                      absl::StrJoin(s.flags(), ", ")});
    }
    h += Table({"cluster", "solver", "kd (RGB)", "ks (RGB)", "ke (RGB)", "cost", "MSE", "Samples", "seconds", "flags"},
               rows, "",
               {term::kCluster, "", term::kKd, term::kKs, term::kKe, term::kCost, term::kMse, term::kSamples, "",
                term::kClusterFlags});
    h += ClustersTable(run);
    h += "</section>";
  }

  // Table 7.1.
  if (run.cameras_size() > 0) {
    h += "<section id=\"table71\"><h2>" + Abbr("Table 7.1", term::kTable71) + ": error per camera</h2>";
    std::vector<std::vector<std::string>> rows;
    std::vector<std::string> names;
    BarSeries brdf{"BRDF atlases", {}, "#dc3912"}, corrected{"with correction atlas", {}, "#3366cc"};
    for (const v1::CameraErrorRow& c : run.cameras()) {
      if (!c.has_mse_brdf()) {  // observed nothing: no error to draw (the warnings say so)
        rows.push_back({c.name(), "absent", "absent", absl::StrCat(c.samples())});
        continue;
      }
      rows.push_back({c.name(), F(c.mse_brdf(), "%.6f"), F(c.mse_correction(), "%.6f"), absl::StrCat(c.samples())});
      names.push_back(c.name());
      brdf.values.push_back(c.mse_brdf());
      corrected.values.push_back(c.mse_correction());
    }
    h += Table({"camera", "BRDF atlas MSE", "correction atlas MSE", "observations"}, rows, "",
               {"", term::kMseBrdf, term::kMseCorrection, term::kObservations});
    h += BarChartSvg("Mean squared error per camera", names, {brdf, corrected}, "");
    h += "</section>";
  }

  // Issue #18: the normals stage.
  if (run.has_normals()) {
    const v1::NormalReport& n = run.normals();
    // Medians over no texel are not figures: left out then.
    h += "<section id=\"normals\"><h2>Surface detail: per-texel normals</h2><p>" + absl::StrCat(n.refined()) +
         " of " + absl::StrCat(n.texels()) + " texels refined" +
         (n.refined() > 0 ? " (median tilt from the mesh normal " + F(n.median_tilt_deg(), "%.2f") +
                                "°, median standard deviation " + F(n.median_sigma_deg(), "%.2f") + "°)"
                          : std::string()) +
         " in " + absl::StrCat(n.passes()) + " passes over the frames; the mesh's normal kept where the refined one "
         "explained the data no better (" + absl::StrCat(n.not_significant()) + " texels, " +
         absl::StrCat(n.cluster_no_better()) + " in clusters whose BRDF it did not fit better), or the data could not "
         "constrain it (" + absl::StrCat(n.few_observations()) + " with too few observations, " +
         absl::StrCat(n.coplanar_lights()) + " lit from nearly coplanar directions, " + absl::StrCat(n.tilt_limit()) +
         " past the tilt limit).";
    if (in.evaluation.has_value() && in.evaluation->has_normals()) {
      const v1::NormalEvaluation& e = in.evaluation->normals();
      h += " Against the truth: median angular error " + F(e.median_deg(), "%.2f") + "°, 90th percentile " +
           F(e.p90_deg(), "%.2f") + "° (the mesh's normals: " + F(e.mesh_median_deg(), "%.2f") + "° / " +
           F(e.mesh_p90_deg(), "%.2f") + "°).";
    }
    h += "</p></section>";
  }
  if (!in.atlases.empty()) {
    h += "<section id=\"atlases\"><h2>Atlases</h2><div class=\"figures\">";
    for (const ReportImage& image : in.atlases) h += Figure(image, 360);
    h += "</div></section>";
  }
  if (!in.cameras.empty()) {
    h += "<section id=\"cameras\"><h2>Input and reconstruction</h2><div class=\"figures\">";
    for (const CameraComparison& c : in.cameras) {
      h += "<figure>" + PngImg(c.input_png, c.camera + " input") + PngImg(c.reconstruction_png, c.camera + " BRDF");
      if (!c.corrected_png.empty()) h += PngImg(c.corrected_png, c.camera + " corrected");
      h += "<figcaption>" + Escape(c.camera) + ", frame " + absl::StrCat(c.frame) +
           ": input, BRDF atlases" + (c.corrected_png.empty() ? "" : ", with the correction atlas") +
           "</figcaption></figure>";
    }
    h += "</div></section>";
  }
  if (!in.relit.empty()) {
    h += "<section id=\"relit\"><h2>" + Abbr("Relit", term::kRelit) +
         ": a light moving around the model on the camera's side</h2><div class=\"relit\">";
    for (const ReportImage& image : in.relit) h += Figure(image);
    h += "</div></section>";
  }
  h += "<p class=\"summary\">Written by <code>mvbrdf report</code>. Terms (hover for a definition): "
       "<code>docs/glossary.md</code> in the mvbrdf repository.</p></body></html>\n";
  return h;
}

}  // namespace mvbrdf::report
