#include "client/stage_lines.h"

#include <algorithm>
#include <cstdio>
#include <utility>

#include "core/scene/names.h"

namespace mvbrdf::client {
namespace {

std::string StageAndKey(const std::string& stage, const std::string& key) {
  std::string text = scene::ShownName(stage);
  if (!key.empty()) text += " \"" + scene::ShownName(key) + "\"";
  return text;
}

}  // namespace

std::string WorkerShown(const std::string& name, const std::string& id) {
  return scene::ShownName(name.empty() ? id : name);
}

std::string StageStartedLine(const v1::StageStarted& s) {
  std::string line = "stage " + StageAndKey(s.stage(), s.key()) + " started";
  if (!s.worker_name().empty() || !s.worker().empty()) line += " on " + WorkerShown(s.worker_name(), s.worker());
  std::string ids;
  if (!s.worker_name().empty() && !s.worker().empty()) ids = "worker " + scene::ShownName(s.worker());
  if (!s.task_id().empty()) ids += (ids.empty() ? "" : ", ") + std::string("task ") + scene::ShownName(s.task_id());
  if (!ids.empty()) line += " (" + ids + ")";
  return line;
}

std::vector<std::string> StageFinishedLines(const v1::StageFinished& f) {
  char text[256];
  std::snprintf(text, sizeof text, " finished in %.2f s", f.seconds());
  std::string line = "stage " + StageAndKey(f.stage(), f.key()) + text;
  if (!f.worker_name().empty()) line += " on " + scene::ShownName(f.worker_name());
  std::vector<std::pair<std::string, double>> metrics(f.metrics().begin(), f.metrics().end());
  std::sort(metrics.begin(), metrics.end());
  std::vector<std::string> lines(1);
  for (const auto& [name, value] : metrics) {
    if (name.rfind("flag/", 0) == 0) {  // a flagged cluster fit (worker/task_runner.cc)
      const std::string rest = name.substr(5);
      const size_t slash = rest.rfind('/');
      lines.push_back("warning: cluster \"" + scene::ShownName(rest.substr(0, slash)) + "\": " +
                      (slash == std::string::npos ? "" : rest.substr(slash + 1)) + " (result.json's clusters[].flags)");
      continue;
    }
    std::snprintf(text, sizeof text, "  %s=%.6g", scene::ShownName(name).c_str(), value);
    line += text;
  }
  lines[0] = line;
  return lines;
}

}  // namespace mvbrdf::client
