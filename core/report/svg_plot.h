// Plots as inline SVG for the HTML report (issue #6): no scripts, no external
// files, readable offline and in print. Numbers are formatted here; text is
// escaped.
#ifndef MVBRDF_CORE_REPORT_SVG_PLOT_H_
#define MVBRDF_CORE_REPORT_SVG_PLOT_H_

#include <string>
#include <vector>

namespace mvbrdf::report {

struct BarSeries {
  std::string name;
  std::vector<double> values;  // one per label
  std::string color;           // CSS colour
};

// Horizontal bars, one group per label, the series side by side; values are
// printed at the bar ends with `unit`.
std::string BarChartSvg(const std::string& title, const std::vector<std::string>& labels,
                        const std::vector<BarSeries>& series, const std::string& unit);

struct ScatterPoint {
  double x = 0.0;
  double y = 0.0;
  std::string label;  // shown beside the point
  int group = 0;      // colour index
  bool marked = false;  // drawn larger, ringed (the chosen operating point)
};

// x against y with the Pareto front (no other point both faster and lower)
// drawn as a step line; `groups` names the colours in a legend.
std::string ParetoSvg(const std::string& title, const std::string& x_label, const std::string& y_label,
                      const std::vector<ScatterPoint>& points, const std::vector<std::string>& groups);

// Indices of the points on the Pareto front (minimise x and y), by x.
std::vector<size_t> ParetoFront(const std::vector<ScatterPoint>& points);

}  // namespace mvbrdf::report

#endif  // MVBRDF_CORE_REPORT_SVG_PLOT_H_
