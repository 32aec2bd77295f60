// The report's pieces, and the whole page in a real browser: Debian's
// Chromium, headless, loads it without script errors, draws every plot and
// image, and its screenshot is not blank.
#include "core/report/report_page.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <regex>

#include "core/report/html.h"
#include "core/report/report_inputs.h"
#include "core/report/svg_plot.h"

namespace mvbrdf::report {
namespace {

namespace fs = std::filesystem;

TEST(HtmlTest, EscapesAndEncodes) {
  EXPECT_EQ(Escape("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("f"), "Zg==");
  EXPECT_EQ(Base64("fo"), "Zm8=");
  EXPECT_EQ(Base64("foo"), "Zm9v");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  // A cell is always text, also when it starts with '<' (a camera named "<img ...>").
  EXPECT_EQ(Table({"a"}, {{"<b>x</b>"}, {"1 < 2"}}),
            "<table><thead><tr><th>a</th></tr></thead><tbody><tr><td>&lt;b&gt;x&lt;/b&gt;"
            "</td></tr><tr><td>1 &lt; 2</td></tr></tbody></table>");
}

TEST(SvgPlotTest, ParetoFrontKeepsOnlyUndominatedPoints) {
  // (time, error): (1, 5) (2, 3) (3, 4) (4, 1) (5, 1): the front is 0, 1, 3.
  std::vector<ScatterPoint> points(5);
  const double xy[5][2] = {{1, 5}, {2, 3}, {3, 4}, {4, 1}, {5, 1}};
  for (int i = 0; i < 5; ++i) points[i].x = xy[i][0], points[i].y = xy[i][1];
  EXPECT_EQ(ParetoFront(points), (std::vector<size_t>{0, 1, 3}));
  const std::string svg = ParetoSvg("t", "x", "y", points, {"g"});
  EXPECT_NE(svg.find("class=\"pareto\""), std::string::npos);
  EXPECT_EQ(std::count(svg.begin(), svg.end(), '\n'), 0);
  size_t circles = 0;
  for (size_t at = svg.find("class=\"point\""); at != std::string::npos; at = svg.find("class=\"point\"", at + 1)) {
    ++circles;
  }
  EXPECT_EQ(circles, 5u);
}

TEST(SvgPlotTest, BarChartScalesToTheLargestValueAndSurvivesNonFinite) {
  const std::string svg = BarChartSvg("T <1>", {"a", "b"}, {{"s", {1.0, NAN}, ""}, {"t", {4.0, 2.0}, ""}}, "s");
  EXPECT_NE(svg.find("T &lt;1&gt;"), std::string::npos);
  EXPECT_NE(svg.find("width=\"460.0\""), std::string::npos);  // 4.0 is the full width
  EXPECT_EQ(svg.find("nan\""), std::string::npos);
}

std::string TestPng(int seed) {
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, cv::Scalar::all(seed), cv::Scalar::all(255));
  std::vector<uchar> png;
  cv::imencode(".png", image, png);
  return std::string(png.begin(), png.end());
}

ReportInputs SampleInputs() {
  ReportInputs in;
  v1::RunReport& run = in.run;
  run.set_scene("studio/scene.json");
  run.set_frames(12);
  run.set_seconds(10.5);
  run.set_chosen_configuration("NE,NW,SE,SW");
  run.set_configuration_rule("lowest E_d; E_a breaks ties");
  run.set_configuration_warning("E_a prefers <C>");
  for (const char* name : {"C", "NE,NW,SE,SW"}) {
    v1::LightConfigurationRow* row = run.add_light_configurations();
    row->set_name(name);
    row->set_e_a(0.003);
    row->set_e_d(std::string(name) == "C" ? 0.005 : 0.0005);
    row->set_e_held_out(std::string(name) == "C" ? 0.004321 : 0.000123);
    row->set_seconds(0.5);
  }
  for (const char* name : {"atlas", "gather_samples", "light_sweep"}) {
    v1::StageRow* stage = run.add_stages();
    stage->set_name(name);
    stage->set_seconds(2.0);
    stage->set_peak_rss_bytes(500u << 20);
  }
  v1::SolverRow* solver = run.add_solvers();
  solver->set_cluster("skin");
  solver->set_solver("levenberg-marquardt");
  for (int c = 0; c < 3; ++c) {
    solver->add_kd(0.3);
    solver->add_ks(0.05);
    solver->add_ke(30);
  }
  for (const char* name : {"skin", "cluster 1"}) {
    v1::ClusterRow* cluster = run.add_clusters();
    cluster->set_name(name);
    cluster->set_texels(std::string(name) == "skin" ? 5000 : 0);
    for (int c = 0; c < 3; ++c) cluster->add_centre(0.3);
    if (std::string(name) != "skin") cluster->add_flags("tiny");
  }
  v1::CameraErrorRow* cam = run.add_cameras();
  cam->set_name("cam0");
  cam->set_mse_brdf(2e-4);
  cam->set_mse_correction(1e-4);
  v1::PlannedStage* planned = run.mutable_plan()->add_stages();
  planned->set_name("light_sweep");
  planned->set_why("8 candidates");
  v1::SkippedStage* skipped = run.mutable_plan()->add_skipped();
  skipped->set_name("atlas");
  skipped->set_reason("the mesh has UVs");
  in.atlases.push_back({"kd", TestPng(0)});
  in.cameras.push_back({"cam0", 6, TestPng(10), TestPng(20), TestPng(30)});
  for (int k = 0; k < 6; ++k) in.relit.push_back({"light " + std::to_string(k), TestPng(k * 20)});
  v1::TradeoffReport tradeoff;
  tradeoff.set_scene("actor");
  for (int k = 0; k < 4; ++k) {
    v1::TradeoffPoint* p = tradeoff.add_points();
    p->set_knob(k < 2 ? "atlas" : "frames");
    p->set_setting(std::to_string(k));
    p->set_seconds(5.0 + k);
    p->set_kd_rmse(0.03 - 0.005 * k);
    p->set_chosen(k == 3);
  }
  in.tradeoff = tradeoff;
  return in;
}

TEST(ReportPageTest, HasEverySectionAndEscapesText) {
  const std::string html = BuildReportHtml(SampleInputs());
  for (const char* id : {"id=\"tradeoff\"", "id=\"plan\"", "id=\"table61\"", "id=\"table62\"", "id=\"table71\"",
                         "id=\"atlases\"", "id=\"cameras\"", "id=\"relit\""}) {
    EXPECT_NE(html.find(id), std::string::npos) << id;
  }
  EXPECT_NE(html.find("E_a prefers &lt;C&gt;"), std::string::npos);
  EXPECT_NE(html.find("the mesh has UVs"), std::string::npos);
  EXPECT_NE(html.find("class=\"chosen\""), std::string::npos);
  // Table 6.1's held-out column (issue #14).
  EXPECT_NE(html.find("<td>0.004321</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>0.000123</td>"), std::string::npos);
  EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org"));  // nothing fetched from the network
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
}

// Issue #20: the terms a reader meets carry their definition (docs/glossary.md)
// as a tooltip, escaped like all text: E_a, E_d and the table names, the
// headings of Tables 6.1, 6.2 and 7.1, kd/ks/ke, Samples, the cluster flags.
TEST(ReportPageTest, TermsHaveEscapedTooltips) {
  const std::string html = BuildReportHtml(SampleInputs());
  for (const char* term :
       {"<th title=\"E_a (thesis Eq. 6.7)", "<th title=\"E_d (thesis Eq. 6.8)", "<abbr title=\"Table 6.1 of the thesis",
        "<abbr title=\"Table 6.2 of the thesis", "<abbr title=\"Table 7.1 of the thesis",
        "<th title=\"kd: diffuse albedo", "<th title=\"ks: specular", "<th title=\"ke: specular exponent",
        "<th title=\"Samples: ", "<th title=\"Flags: why", "<abbr title=\"Configuration margin", "docs/glossary.md",
        "<th title=\"Held-out error (issue #14)"}) {
    EXPECT_NE(html.find(term), std::string::npos) << term;
  }
  // Every title attribute holds escaped text only: "< 0.5 %" in the flags'
  // definition comes out as "&lt; 0.5 %".
  size_t titles = 0;
  for (size_t at = html.find("title=\""); at != std::string::npos; at = html.find("title=\"", at + 1)) {
    const size_t end = html.find('"', at + 7);
    ASSERT_NE(end, std::string::npos);
    const std::string value = html.substr(at + 7, end - at - 7);
    EXPECT_EQ(value.find_first_of("<>"), std::string::npos) << value;
    ++titles;
  }
  EXPECT_GE(titles, 20u);
  EXPECT_NE(html.find("tiny (too few texels, &lt; 0.5 % of the seen ones"), std::string::npos);
}

// Issue #18: a run with the normals stage gets a section with its counts and,
// with a truth, the angular error beside the mesh normals'.
TEST(ReportPageTest, NormalsSectionShowsTheStageAndTheTruth) {
  ReportInputs in = SampleInputs();
  EXPECT_EQ(BuildReportHtml(in).find("id=\"normals\""), std::string::npos);  // no stage: no section
  v1::NormalReport* n = in.run.mutable_normals();
  n->set_texels(1000);
  n->set_refined(900);
  n->set_not_significant(70);
  n->set_passes(4);
  n->set_median_tilt_deg(8.25);
  std::string html = BuildReportHtml(in);
  ASSERT_NE(html.find("id=\"normals\""), std::string::npos);
  EXPECT_NE(html.find("900 of 1000 texels refined (median tilt from the mesh normal 8.25°"), std::string::npos);
  EXPECT_NE(html.find("(70 texels,"), std::string::npos);
  v1::EvaluationReport evaluation;
  evaluation.mutable_normals()->set_median_deg(1.25);
  evaluation.mutable_normals()->set_mesh_median_deg(11.98);
  in.evaluation = evaluation;
  html = BuildReportHtml(in);
  EXPECT_NE(html.find("median angular error 1.25°"), std::string::npos);
  EXPECT_NE(html.find("(the mesh's normals: 11.98°"), std::string::npos);
}

// Issue #14: the Calibration section says what was refined, by how much and
// with what uncertainty, and against the truth; or why nothing was refined.
TEST(ReportPageTest, CalibrationSectionShowsTheRefinementOrWhyNot) {
  ReportInputs in = SampleInputs();
  EXPECT_EQ(BuildReportHtml(in).find("id=\"calibration\""), std::string::npos);  // no calibration: no section
  v1::CalibrationReport* c = in.run.mutable_calibration();
  c->set_cameras_mode("auto");
  c->set_cameras_refined(false);
  c->set_cameras_decision("cross-camera residual 1.02 x the noise < 1.5");
  std::string html = BuildReportHtml(in);
  ASSERT_NE(html.find("id=\"calibration\""), std::string::npos);
  EXPECT_NE(html.find("Cameras not refined (--refine-cameras auto): cross-camera residual 1.02 x the noise &lt; 1.5"),
            std::string::npos);

  c->set_cameras_refined(true);
  c->set_cameras_decision("residual 3.1 x the noise");
  c->set_frames_used(8);
  c->set_cameras_seconds(4.25);
  v1::CameraRefinementRow* row = c->add_cameras();
  row->set_name("cam<0>");
  row->set_rotation_change_deg(0.2987);
  row->set_rotation_sigma_deg(0.004);
  row->set_centre_change(0.0049);
  row->set_centre_sigma(0.0003);
  row->set_focal_change(0.001);
  row->set_reprojection_change_px(1.062);
  row->set_residual_before(0.031);
  row->set_residual_after(0.012);
  row->set_observations(120000);
  c->set_lights_mode("auto");
  c->set_lights_refined(true);
  c->set_lights_decision("after the sweep");
  v1::LightRefinementRow* light = c->add_lights();
  light->set_name("NE");
  for (double v : {1.0, 2.0, 3.0}) light->add_position_before(v);
  light->set_position_change(0.012);
  light->set_position_sigma(0.002);
  for (double v : {1.0, 1.0, 1.0}) light->add_intensity_before(v);
  for (double v : {1.1, 1.0, 0.9}) light->add_intensity_after(v);
  light->set_intensity_rel_sigma(0.01);
  v1::EvaluationReport evaluation;
  v1::CameraTruthRow* truth = evaluation.add_cameras();
  truth->set_name("cam<0>");
  truth->set_rotation_error_deg_before(0.3);
  truth->set_rotation_error_deg_after(0.01);
  truth->set_reprojection_error_px_before(1.06);
  truth->set_reprojection_error_px_after(0.04);
  v1::LightTruthRow* light_truth = evaluation.add_lights();
  light_truth->set_name("NE");
  light_truth->set_intensity_rel_error_before(0.2);
  light_truth->set_intensity_rel_error_after(0.02);
  in.evaluation = evaluation;
  html = BuildReportHtml(in);
  const size_t at = html.find("id=\"calibration\"");
  ASSERT_NE(at, std::string::npos);
  const std::string section = html.substr(at, html.find("</section>", at) - at);
  for (const char* text :
       {"Cameras refined (--refine-cameras auto) on 8 frames in 4.2 s: residual 3.1 x the noise",
        "<td>cam&lt;0&gt;</td>", "<td>0.2987 ± 0.004</td>", "<td>0.0049 ± 0.0003</td>", "<td>0.100</td>",
        "<td>1.062</td>", "<td>0.031 → 0.012</td>", "Lights refined (--refine-lights auto) in 0.0 s: after the sweep",
        "<td>0.012 ± 0.002</td>", "(1 / 1 / 1) → (1.1 / 1 / 0.9)", "± 1 %", "<td>0.3000 → 0.0100</td>",
        "<td>1.060 → 0.040</td>", "<td>0.200 → 0.020</td>", "common scale"}) {
    EXPECT_NE(section.find(text), std::string::npos) << text << "\n" << section;
  }
  EXPECT_EQ(section.find("not used"), std::string::npos);
}

// Issue #20: a cluster that is not a material is marked in the clusters table.
TEST(ReportPageTest, TinyClusterIsMarked) {
  const std::string html = BuildReportHtml(SampleInputs());
  const size_t table = html.find("id=\"clusters\"");
  ASSERT_NE(table, std::string::npos);
  EXPECT_NE(html.find("<td>cluster 1</td><td>0</td>", table), std::string::npos);
  EXPECT_NE(html.find("<td>tiny</td>", table), std::string::npos);
}

// Issue #15: a GGX cluster's row names its F90 / F0 and the grazing support it
// is drawn within; a cluster without support (0) names none.
TEST(ReportPageTest, GgxClustersShowTheirGrazingSupport) {
  ReportInputs in = SampleInputs();
  in.run.set_brdf("ggx");
  ASSERT_GE(in.run.clusters_size(), 2);
  for (int k = 0; k < 2; ++k) {
    v1::ClusterRow* c = in.run.mutable_clusters(k);
    for (int i = 0; i < 3; ++i) {
      c->add_f0(0.04);
      c->add_roughness(0.3);
      c->add_f90_ratio(25.0);
    }
  }
  in.run.mutable_clusters(0)->set_ggx_grazing_support(0.0123);
  const std::string html = BuildReportHtml(in);
  const size_t table = html.find("id=\"clusters\"");
  ASSERT_NE(table, std::string::npos);
  EXPECT_NE(html.find("grazing support 0.012", table), std::string::npos);
  EXPECT_EQ(html.find("grazing support", html.find("grazing support 0.012", table) + 1), std::string::npos)
      << "only the cluster with a support names one";
}

// Issue #20: half of the relit sequence was black, the light circling behind
// the model. The path stays on the camera's side, whichever way the camera
// looks and whichever axis is up: every light sees the model's camera-facing
// side (its direction from the centre within 90 degrees of the camera's), it
// swings from the camera's left to its right, and it stays above the centre
// in the camera's up direction.
TEST(RelitLightPathTest, StaysOnTheCameraSide) {
  const glm::vec3 lo(-1.0f, -2.0f, -0.5f), hi(1.0f, 2.0f, 0.5f);
  const glm::vec3 centre = 0.5f * (lo + hi);
  // Looking at the origin from +z with world y up, and from +x with world z up.
  for (int view = 0; view < 2; ++view) {
    scene::CameraModel camera;
    camera.fx = camera.fy = 100.0;
    // Rows: the camera's x (right), y (down) and z (forward) in the world.
    const glm::dvec3 right = view == 0 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 down = view == 0 ? glm::dvec3(0, -1, 0) : glm::dvec3(0, 0, -1);
    const glm::dvec3 forward = glm::cross(right, down);
    camera.cam_from_world_rotation = glm::transpose(glm::dmat3(right, down, forward));
    const glm::dvec3 position = -6.0 * forward;
    camera.cam_from_world_translation = -(camera.cam_from_world_rotation * position);
    ASSERT_LT(glm::length(camera.CenterInWorld() - position), 1e-9);
    const std::vector<RelitLight> path = RelitLightPath(camera, lo, hi, 12);
    ASSERT_EQ(path.size(), 12u);
    EXPECT_EQ(path.front().degrees, -80);
    EXPECT_EQ(path.back().degrees, 80);
    const glm::vec3 to_camera = glm::normalize(glm::vec3(position) - centre);
    for (size_t k = 0; k < path.size(); ++k) {
      const glm::vec3 to_light = glm::normalize(path[k].position - centre);
      EXPECT_GT(glm::dot(to_light, to_camera), 0.1f) << "view " << view << " light " << k;
      EXPECT_GT(glm::dot(to_light, -glm::vec3(down)), 0.3f) << "view " << view << " light " << k;
      if (k > 0) {
        EXPECT_GT(glm::dot(path[k].position - path[k - 1].position, glm::vec3(right)), 0.0f) << "left to right";
      }
    }
  }
  EXPECT_TRUE(RelitLightPath(scene::CameraModel{}, lo, hi, 0).empty());
}

constexpr char kHostile[] = "<img src=x onerror=alert(1)>\"q'</script><script>alert(2)</script>";

// Sets every string field of `message` (recursively, repeated ones too, adding
// an element to empty repeated messages and strings) to kHostile.
void FillStrings(google::protobuf::Message* message, int depth = 0) {
  using google::protobuf::FieldDescriptor;
  const google::protobuf::Descriptor* d = message->GetDescriptor();
  const google::protobuf::Reflection* r = message->GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    if (f->type() == FieldDescriptor::TYPE_STRING) {
      if (!f->is_repeated()) {
        r->SetString(message, f, kHostile);
      } else {
        if (r->FieldSize(*message, f) == 0) r->AddString(message, f, kHostile);
        for (int k = 0; k < r->FieldSize(*message, f); ++k) r->SetRepeatedString(message, f, k, kHostile);
      }
    } else if (f->type() == FieldDescriptor::TYPE_MESSAGE && depth < 4) {
      if (!f->is_repeated()) {
        FillStrings(r->MutableMessage(message, f), depth + 1);
      } else {
        if (r->FieldSize(*message, f) == 0) r->AddMessage(message, f);
        for (int k = 0; k < r->FieldSize(*message, f); ++k) {
          FillStrings(r->MutableRepeatedMessage(message, f, k), depth + 1);
        }
      }
    }
  }
}

TEST(ReportPageTest, EveryStringFromTheRunIsEscapedInTextAndAttributes) {
  ReportInputs in = SampleInputs();
  FillStrings(&in.run);
  v1::EvaluationReport evaluation;
  FillStrings(&evaluation);
  in.evaluation = evaluation;
  FillStrings(&*in.tradeoff);
  for (ReportImage& image : in.atlases) image.caption = kHostile;
  for (ReportImage& image : in.relit) image.caption = kHostile;
  for (CameraComparison& c : in.cameras) c.camera = kHostile;
  const std::string html = BuildReportHtml(in);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_EQ(html.find("alert(2)</script>"), std::string::npos);
  EXPECT_EQ(html.find("\"q'"), std::string::npos);  // a quote could end an attribute
  // The page's own check script is its only script.
  size_t scripts = 0;
  for (size_t at = html.find("<script"); at != std::string::npos; at = html.find("<script", at + 1)) ++scripts;
  EXPECT_EQ(scripts, 1u);
  // Every image is an embedded PNG (no image from a name).
  for (size_t at = html.find("<img"); at != std::string::npos; at = html.find("<img", at + 1)) {
    EXPECT_EQ(html.compare(at, 32, "<img src=\"data:image/png;base64,"), 0) << html.substr(at, 60);
  }
  EXPECT_NE(html.find("&lt;img src=x onerror=alert(1)&gt;&quot;q&#39;&lt;/script&gt;"), std::string::npos);
}

// Runs `command`, returns its stdout.
std::string Shell(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buf[4096];
  size_t n = 0;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) out.append(buf, n);
  pclose(pipe);
  return out;
}

TEST(ReportBrowserTest, ChromiumLoadsThePageDrawsEveryPlotAndTheScreenshotIsNotBlank) {
  const char* chromium = "/usr/bin/chromium";
  ASSERT_TRUE(fs::exists(chromium)) << "Debian's chromium is missing: run scripts/install-deps";
  const fs::path dir = fs::temp_directory_path() / ("mvbrdf_report_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path page = dir / "report.html";
  {
    std::ofstream out(page);
    out << BuildReportHtml(SampleInputs());
  }
  const std::string flags = "--headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
                            "--disable-background-networking --disable-component-update --disable-sync "
                            "--virtual-time-budget=5000 --user-data-dir=" + (dir / "profile").string();
  const std::string dom = Shell(std::string(chromium) + " " + flags + " --dump-dom file://" + page.string() +
                              " 2>/dev/null");
  EXPECT_NE(dom.find("data-report-ready=\"yes\""), std::string::npos) << dom.substr(0, 300);
  EXPECT_EQ(dom.find("data-report-errors=\""), std::string::npos) << "a script error on the page";
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex("data-plots=\"(\\d+)/(\\d+)\"")));
  EXPECT_EQ(std::stoi(m[1]), 6);  // 2 Pareto, time, memory, E_d, Table 7.1
  EXPECT_EQ(m[1], m[2]) << "every plot has a size";
  ASSERT_TRUE(std::regex_search(dom, m, std::regex("data-images=\"(\\d+)/(\\d+)\"")));
  EXPECT_EQ(std::stoi(m[1]), 1 + 3 + 6);
  EXPECT_EQ(m[1], m[2]) << "every image decoded";

  const fs::path shot = dir / "shot.png";
  Shell(std::string(chromium) + " " + flags + " --window-size=1200,1600 --screenshot=" + shot.string() + " file://" +
      page.string() + " 2>/dev/null");
  const cv::Mat image = cv::imread(shot.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(image.empty()) << "no screenshot";
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  EXPECT_GT(stddev[0], 10.0) << "the screenshot is (nearly) blank";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mvbrdf::report
