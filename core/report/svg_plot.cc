#include "core/report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "core/report/html.h"

namespace mvbrdf::report {
namespace {

const char* kPalette[] = {"#3366cc", "#dc3912", "#ff9900", "#109618", "#990099", "#0099c6", "#dd4477", "#66aa00"};

std::string Num(double v) {
  char buf[64];
  if (v != 0.0 && (std::fabs(v) < 1e-3 || std::fabs(v) >= 1e5)) {
    std::snprintf(buf, sizeof(buf), "%.3g", v);
  } else {
    std::snprintf(buf, sizeof(buf), "%.4g", v);
  }
  return buf;
}

std::string Fixed(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", v);
  return buf;
}

// "Nice" axis ticks covering [lo, hi].
std::vector<double> Ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo)) {
    ticks.push_back(lo);
    return ticks;
  }
  const double raw = (hi - lo) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * magnitude >= raw) {
      step = m * magnitude;
      break;
    }
  }
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-12 * std::fabs(hi); t += step) ticks.push_back(t);
  return ticks;
}

}  // namespace

std::string BarChartSvg(const std::string& title, const std::vector<std::string>& labels,
                        const std::vector<BarSeries>& series, const std::string& unit) {
  const double label_w = 170, plot_w = 460, value_w = 90, bar_h = 14, gap = 8, top = 34;
  const size_t n = series.size();
  const double group_h = static_cast<double>(n) * bar_h + gap;
  const double height = top + static_cast<double>(labels.size()) * group_h + 10 + 18 * static_cast<double>(n > 1);
  double max_v = 0.0;
  for (const BarSeries& s : series) {
    for (double v : s.values) {
      if (std::isfinite(v)) max_v = std::max(max_v, v);
    }
  }
  if (!(max_v > 0.0)) max_v = 1.0;
  std::string svg = "<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    Fixed(label_w + plot_w + value_w) + "\" height=\"" + Fixed(height) + "\" role=\"img\">";
  svg += "<title>" + Escape(title) + "</title>";
  svg += "<text x=\"0\" y=\"18\" class=\"plot-title\">" + Escape(title) + "</text>";
  for (size_t i = 0; i < labels.size(); ++i) {
    const double y0 = top + static_cast<double>(i) * group_h;
    svg += "<text x=\"" + Fixed(label_w - 6) + "\" y=\"" + Fixed(y0 + group_h / 2) +
           "\" text-anchor=\"end\" dominant-baseline=\"middle\">" + Escape(labels[i]) + "</text>";
    for (size_t k = 0; k < n; ++k) {
      const double v = i < series[k].values.size() ? series[k].values[i] : 0.0;
      const double w = std::isfinite(v) ? std::max(0.0, v / max_v * plot_w) : 0.0;
      const double y = y0 + static_cast<double>(k) * bar_h;
      const std::string color = series[k].color.empty() ? kPalette[k % 8] : series[k].color;
      svg += "<rect x=\"" + Fixed(label_w) + "\" y=\"" + Fixed(y) + "\" width=\"" + Fixed(std::max(w, 0.5)) +
             "\" height=\"" + Fixed(bar_h - 2) + "\" fill=\"" + color + "\"><title>" + Escape(series[k].name) + ": " +
             Num(v) + " " + Escape(unit) + "</title></rect>";
      svg += "<text x=\"" + Fixed(label_w + w + 4) + "\" y=\"" + Fixed(y + bar_h / 2) +
             "\" dominant-baseline=\"middle\" class=\"value\">" + Num(v) + " " + Escape(unit) + "</text>";
    }
  }
  if (n > 1) {
    double x = label_w;
    for (size_t k = 0; k < n; ++k) {
      const std::string color = series[k].color.empty() ? kPalette[k % 8] : series[k].color;
      svg += "<rect x=\"" + Fixed(x) + "\" y=\"" + Fixed(height - 16) + "\" width=\"10\" height=\"10\" fill=\"" +
             color + "\"/><text x=\"" + Fixed(x + 14) + "\" y=\"" + Fixed(height - 7) + "\">" +
             Escape(series[k].name) + "</text>";
      x += 24 + 7.0 * static_cast<double>(series[k].name.size());
    }
  }
  svg += "</svg>";
  return svg;
}

std::vector<size_t> ParetoFront(const std::vector<ScatterPoint>& points) {
  std::vector<size_t> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return points[a].x != points[b].x ? points[a].x < points[b].x : points[a].y < points[b].y;
  });
  std::vector<size_t> front;
  double best_y = INFINITY;
  for (size_t i : order) {
    if (!std::isfinite(points[i].x) || !std::isfinite(points[i].y)) continue;
    if (points[i].y < best_y) {
      front.push_back(i);
      best_y = points[i].y;
    }
  }
  return front;
}

std::string ParetoSvg(const std::string& title, const std::string& x_label, const std::string& y_label,
                      const std::vector<ScatterPoint>& points, const std::vector<std::string>& groups) {
  const double width = 720, height = 420, left = 70, right = 170, top = 34, bottom = 50;
  const double pw = width - left - right, ph = height - top - bottom;
  double x_lo = INFINITY, x_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  for (const ScatterPoint& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    x_lo = std::min(x_lo, p.x);
    x_hi = std::max(x_hi, p.x);
    y_lo = std::min(y_lo, p.y);
    y_hi = std::max(y_hi, p.y);
  }
  if (!std::isfinite(x_lo)) x_lo = 0, x_hi = 1, y_lo = 0, y_hi = 1;
  x_lo = std::min(0.0, x_lo);
  y_lo = std::min(0.0, y_lo);
  x_hi = x_hi > x_lo ? x_hi * 1.05 : x_lo + 1;
  y_hi = y_hi > y_lo ? y_hi * 1.08 : y_lo + 1;
  const auto sx = [&](double x) { return left + (x - x_lo) / (x_hi - x_lo) * pw; };
  const auto sy = [&](double y) { return top + ph - (y - y_lo) / (y_hi - y_lo) * ph; };
  std::string svg = "<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Fixed(width) +
                    "\" height=\"" + Fixed(height) + "\" role=\"img\">";
  svg += "<title>" + Escape(title) + "</title>";
  svg += "<text x=\"0\" y=\"18\" class=\"plot-title\">" + Escape(title) + "</text>";
  svg += "<rect x=\"" + Fixed(left) + "\" y=\"" + Fixed(top) + "\" width=\"" + Fixed(pw) + "\" height=\"" + Fixed(ph) +
         "\" fill=\"none\" stroke=\"#999\"/>";
  for (double t : Ticks(x_lo, x_hi, 6)) {
    svg += "<line x1=\"" + Fixed(sx(t)) + "\" x2=\"" + Fixed(sx(t)) + "\" y1=\"" + Fixed(top) + "\" y2=\"" +
           Fixed(top + ph) + "\" stroke=\"#eee\"/><text x=\"" + Fixed(sx(t)) + "\" y=\"" + Fixed(top + ph + 16) +
           "\" text-anchor=\"middle\">" + Num(t) + "</text>";
  }
  for (double t : Ticks(y_lo, y_hi, 6)) {
    svg += "<line x1=\"" + Fixed(left) + "\" x2=\"" + Fixed(left + pw) + "\" y1=\"" + Fixed(sy(t)) + "\" y2=\"" +
           Fixed(sy(t)) + "\" stroke=\"#eee\"/><text x=\"" + Fixed(left - 6) + "\" y=\"" + Fixed(sy(t)) +
           "\" text-anchor=\"end\" dominant-baseline=\"middle\">" + Num(t) + "</text>";
  }
  svg += "<text x=\"" + Fixed(left + pw / 2) + "\" y=\"" + Fixed(height - 12) + "\" text-anchor=\"middle\">" +
         Escape(x_label) + "</text>";
  svg += "<text transform=\"translate(14," + Fixed(top + ph / 2) + ") rotate(-90)\" text-anchor=\"middle\">" +
         Escape(y_label) + "</text>";
  const std::vector<size_t> front = ParetoFront(points);
  if (front.size() > 1) {
    std::string path;
    for (size_t k = 0; k < front.size(); ++k) {
      const ScatterPoint& p = points[front[k]];
      if (k == 0) {
        path += "M" + Fixed(sx(p.x)) + "," + Fixed(sy(p.y));
      } else {
        path += " H" + Fixed(sx(p.x)) + " V" + Fixed(sy(p.y));
      }
    }
    svg += "<path class=\"pareto\" d=\"" + path + "\" fill=\"none\" stroke=\"#555\" stroke-dasharray=\"4 3\"/>";
  }
  for (const ScatterPoint& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    const std::string color = kPalette[static_cast<size_t>(std::max(p.group, 0)) % 8];
    svg += "<circle class=\"point\" cx=\"" + Fixed(sx(p.x)) + "\" cy=\"" + Fixed(sy(p.y)) + "\" r=\"" +
           (p.marked ? "7" : "4.5") + "\" fill=\"" + color + "\"" +
           (p.marked ? " stroke=\"#000\" stroke-width=\"2.5\"" : "") + "><title>" + Escape(p.label) + ": " +
           Num(p.x) + ", " + Num(p.y) + "</title></circle>";
    svg += "<text x=\"" + Fixed(sx(p.x) + 7) + "\" y=\"" + Fixed(sy(p.y) - 6) + "\" class=\"value\">" +
           Escape(p.label) + "</text>";
  }
  for (size_t g = 0; g < groups.size(); ++g) {
    const double y = top + 10 + 18.0 * static_cast<double>(g);
    svg += "<circle cx=\"" + Fixed(width - right + 16) + "\" cy=\"" + Fixed(y) + "\" r=\"5\" fill=\"" +
           kPalette[g % 8] + "\"/><text x=\"" + Fixed(width - right + 26) + "\" y=\"" + Fixed(y + 4) + "\">" +
           Escape(groups[g]) + "</text>";
  }
  const double y = top + 10 + 18.0 * static_cast<double>(groups.size());
  svg += "<circle cx=\"" + Fixed(width - right + 16) + "\" cy=\"" + Fixed(y) +
         "\" r=\"6\" fill=\"#fff\" stroke=\"#000\" stroke-width=\"2.5\"/><text x=\"" + Fixed(width - right + 26) +
         "\" y=\"" + Fixed(y + 4) + "\">chosen (defaults)</text>";
  svg += "</svg>";
  return svg;
}

}  // namespace mvbrdf::report
