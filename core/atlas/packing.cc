// Minimal-area rectangles and the outline packer with a bisection over the
// global scale.
#include "core/atlas/packing.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/atlas/charts.h"

namespace mvbrdf::atlas::internal {
namespace {

double Cross(const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Andrew's monotone chain; counter-clockwise, no collinear points.
std::vector<glm::dvec2> ConvexHull(std::vector<glm::dvec2> points) {
  std::sort(points.begin(), points.end(),
            [](const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  std::vector<glm::dvec2> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

OrientedRect BoundsAlong(const std::vector<glm::dvec2>& points, const glm::dvec2& axis_x) {
  OrientedRect rect;
  rect.axis_x = axis_x;
  rect.axis_y = glm::dvec2(-axis_x.y, axis_x.x);
  glm::dvec2 lo(HUGE_VAL), hi(-HUGE_VAL);
  for (const glm::dvec2& p : points) {
    const glm::dvec2 q(glm::dot(p, rect.axis_x), glm::dot(p, rect.axis_y));
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  rect.min = lo;
  rect.extent = hi - lo;
  return rect;
}

// A chart's footprint on the texel grid at one scale is a CV_8UC1 bitmap of
// its box, row j holding the texels of y in [j, j + 1] (row 0 at y = 0, so
// the rows run upwards), 1 where a triangle touches the texel.

// The texels of the box the chart's triangles touch at `texels_per_unit`
// (clamped to the box: a vertex on its far edge touches no texel beyond):
// texel (i, j), the closed square [i, i + 1] x [j, j + 1], is touched when the
// closed triangle meets it, i.e. when [i, i + 1] meets the x extent of the
// triangle's part in the slab j <= y <= j + 1 (a convex polygon whose
// vertices are the triangle's in the slab and its edges' crossings of the
// slab's lines). Degenerate triangles (segments, points) are handled alike.
cv::Mat RasterizeFootprint(const ChartShape& chart, double texels_per_unit) {
  constexpr double kSlack = 1e-9;  // texels: conservative against rounding
  cv::Mat f(BoxTexels(chart.extent.y, texels_per_unit), BoxTexels(chart.extent.x, texels_per_unit), CV_8UC1,
            cv::Scalar(0));
  for (const std::array<glm::dvec2, 3>& tri : chart.triangles) {
    std::array<glm::dvec2, 3> t;
    double y_lo = HUGE_VAL, y_hi = -HUGE_VAL;
    for (int k = 0; k < 3; ++k) {
      t[k] = texels_per_unit * tri[k];
      y_lo = std::min(y_lo, t[k].y);
      y_hi = std::max(y_hi, t[k].y);
    }
    const int j0 = std::clamp(static_cast<int>(std::ceil(y_lo - 1.0 - kSlack)), 0, f.rows - 1);
    const int j1 = std::clamp(static_cast<int>(std::floor(y_hi + kSlack)), 0, f.rows - 1);
    for (int j = j0; j <= j1; ++j) {
      const double s0 = j - kSlack, s1 = j + 1.0 + kSlack;
      double x_lo = HUGE_VAL, x_hi = -HUGE_VAL;
      for (int k = 0; k < 3; ++k) {
        const glm::dvec2& p = t[k];
        const glm::dvec2& q = t[(k + 1) % 3];
        if (p.y >= s0 && p.y <= s1) {
          x_lo = std::min(x_lo, p.x);
          x_hi = std::max(x_hi, p.x);
        }
        for (const double line : {s0, s1}) {
          if ((p.y < line && q.y > line) || (p.y > line && q.y < line)) {
            const double x = p.x + (q.x - p.x) * ((line - p.y) / (q.y - p.y));
            x_lo = std::min(x_lo, x);
            x_hi = std::max(x_hi, x);
          }
        }
      }
      if (!(x_lo <= x_hi)) continue;
      const int i0 = std::clamp(static_cast<int>(std::ceil(x_lo - 1.0 - kSlack)), 0, f.cols - 1);
      const int i1 = std::clamp(static_cast<int>(std::floor(x_hi + kSlack)), 0, f.cols - 1);
      if (i0 <= i1) std::fill_n(f.ptr<uint8_t>(j) + i0, i1 - i0 + 1, uint8_t{1});
    }
  }
  return f;
}

// The footprint grown by g texels in x and y (Chebyshev), its box g larger on
// every side.
cv::Mat Grow(const cv::Mat& f, int g) {
  cv::Mat bordered, grown;
  cv::copyMakeBorder(f, bordered, g, g, g, g, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(bordered, grown, cv::Mat::ones(2 * g + 1, 2 * g + 1, CV_8UC1), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
             cv::Scalar(0));
  return grown;
}

// The footprint turned by `turns` quarter turns counter-clockwise inside its
// box, as PackedLayout::Place turns points: texel (i, j) of a w x h box goes
// to (h - 1 - j, i), (w - 1 - i, h - 1 - j) or (j, w - 1 - i). (The rows run
// upwards, so a counter-clockwise turn is OpenCV's clockwise one.)
cv::Mat Turn(const cv::Mat& f, int turns) {
  if (turns == 0) return f;
  constexpr cv::RotateFlags kCodes[] = {cv::ROTATE_90_CLOCKWISE, cv::ROTATE_180, cv::ROTATE_90_COUNTERCLOCKWISE};
  cv::Mat t;
  cv::rotate(f, t, kCodes[turns - 1]);
  return t;
}

// Runs of set texels per row: [first, last] column pairs.
struct Spans {
  int width = 0, height = 0;
  std::vector<std::vector<std::pair<int, int>>> rows;
};

Spans ToSpans(const cv::Mat& f) {
  Spans s;
  s.width = f.cols;
  s.height = f.rows;
  s.rows.resize(static_cast<size_t>(f.rows));
  for (int j = 0; j < f.rows; ++j) {
    const uint8_t* row = f.ptr<uint8_t>(j);
    for (int i = 0; i < f.cols;) {
      if (row[i] == 0) {
        ++i;
        continue;
      }
      int k = i;
      while (k + 1 < f.cols && row[k + 1] != 0) ++k;
      s.rows[static_cast<size_t>(j)].emplace_back(i, k);
      i = k + 1;
    }
  }
  return s;
}

// The atlas's occupied texels, a bit per texel, rows of 64-bit words, and
// each row's longest run of free texels.
class Occupancy {
 public:
  explicit Occupancy(int size)
      : size_(size),
        words_((size + 63) / 64),
        bits_(static_cast<size_t>(size) * words_, 0),
        longest_free_(static_cast<size_t>(size), size) {}

  // The first occupied column in [from, to] of `row`, or to + 1.
  int FirstSet(int row, int from, int to) const { return Scan(row, from, to, 0); }

  // The first free column at or after `from` in `row`, or size.
  int FirstClear(int row, int from) const { return Scan(row, from, size_ - 1, ~uint64_t{0}); }

  int LongestFree(int row) const { return longest_free_[static_cast<size_t>(row)]; }

  void Set(int row, int column) {
    bits_[static_cast<size_t>(row) * words_ + (column >> 6)] |= uint64_t{1} << (column & 63);
  }

  // Recomputes LongestFree of `row` after Set.
  void Update(int row) {
    int longest = 0, from = FirstClear(row, 0);
    while (from < size_) {
      const int hit = FirstSet(row, from, size_ - 1);
      longest = std::max(longest, hit - from);
      from = hit < size_ ? FirstClear(row, hit) : size_;
    }
    longest_free_[static_cast<size_t>(row)] = longest;
  }

 private:
  // The first column in [from, to] of `row` whose bit, xor-ed with `flip`'s,
  // is set, or to + 1 (the words' bits past `size` are 0, so they count as
  // free: the bound to keeps them out).
  int Scan(int row, int from, int to, uint64_t flip) const {
    const uint64_t* words = &bits_[static_cast<size_t>(row) * words_];
    int w = from >> 6;
    uint64_t word = (words[w] ^ flip) & (~uint64_t{0} << (from & 63));
    while (true) {
      if (word != 0) {
        const int at = (w << 6) + __builtin_ctzll(word);
        return at <= to ? at : to + 1;
      }
      if (++w > (to >> 6)) return to + 1;
      word = words[w] ^ flip;
    }
  }

  int size_;
  int words_;
  std::vector<uint64_t> bits_;
  std::vector<int> longest_free_;
};

// The lowest row (then column) at which `grown` (a footprint grown by g, its
// box g larger on every side) meets nothing in `occupied`, with the box inside
// [g, size - g); rows above `max_row` are not tried. False when none.
bool LowestFit(const Occupancy& occupied, const Spans& grown, int size, int g, int max_row, glm::ivec2* at) {
  const int w = grown.width - 2 * g, h = grown.height - 2 * g;
  const int last_x = size - g - w, last_y = std::min(size - g - h, max_row);
  // Each row's longest run, which must fit in a free run of the atlas row.
  std::vector<int> widest(static_cast<size_t>(grown.height), 0);
  for (int j = 0; j < grown.height; ++j) {
    for (const auto& [first, last] : grown.rows[static_cast<size_t>(j)]) {
      widest[static_cast<size_t>(j)] = std::max(widest[static_cast<size_t>(j)], last - first + 1);
    }
  }
  int start = 0;  // the row that failed last: it is likely to fail again
  for (int y = g; y <= last_y; ++y) {
    bool possible = true;
    for (int j = 0; j < grown.height && possible; ++j) {
      possible = occupied.LongestFree(y - g + j) >= widest[static_cast<size_t>(j)];
    }
    if (!possible) continue;
    int x = g;
    while (x <= last_x) {
      bool fits = true;
      for (int k = 0; k < grown.height && fits; ++k) {
        const int j = (start + k) % grown.height;
        for (const auto& [first, last] : grown.rows[static_cast<size_t>(j)]) {
          const int from = x - g + first, to = x - g + last;
          const int hit = occupied.FirstSet(y - g + j, from, to);
          if (hit <= to) {
            // Every x up to here puts this run on the occupied run from the hit on.
            x = occupied.FirstClear(y - g + j, hit) - (first - g);
            start = j;
            fits = false;
            break;
          }
        }
      }
      if (fits) {
        *at = glm::ivec2(x, y);
        return true;
      }
    }
  }
  return false;
}

// Packs every chart at `texels_per_unit` in `order`; false when one does not fit.
bool PackAt(const std::vector<ChartShape>& charts, const std::vector<size_t>& order, double texels_per_unit, int size,
            int gutter, PackedLayout* layout) {
  layout->texels_per_unit = texels_per_unit;
  layout->offsets.assign(charts.size(), glm::ivec2(0));
  layout->turns.assign(charts.size(), 0);
  Occupancy occupied(size);
  for (size_t c : order) {
    const cv::Mat footprint = RasterizeFootprint(charts[c], texels_per_unit);
    const cv::Mat grown = Grow(footprint, gutter);
    // A 1-texel footprint looks the same in every turn.
    const int turns = footprint.total() == 1 ? 1 : 4;
    // The turn and place whose top (box row + box height) is lowest, then
    // the lowest row, then column: lying a strip down beats standing it up.
    int best_turn = -1, best_top = 2 * size;
    glm::ivec2 best(0, size);
    for (int turn = 0; turn < turns; ++turn) {
      const int h = turn % 2 == 0 ? footprint.rows : footprint.cols;
      glm::ivec2 at;
      if (!LowestFit(occupied, ToSpans(Turn(grown, turn)), size, gutter, best_top - h, &at)) continue;
      const int top = at.y + h;
      if (top < best_top || (top == best_top && (at.y < best.y || (at.y == best.y && at.x < best.x)))) {
        best = at;
        best_turn = turn;
        best_top = top;
      }
    }
    if (best_turn < 0) return false;
    layout->offsets[c] = best;
    layout->turns[c] = best_turn;
    const cv::Mat placed = Turn(footprint, best_turn);
    for (int j = 0; j < placed.rows; ++j) {
      for (int i = 0; i < placed.cols; ++i) {
        if (placed.at<uint8_t>(j, i) != 0) occupied.Set(best.y + j, best.x + i);
      }
      occupied.Update(best.y + j);
    }
  }
  return true;
}

}  // namespace

OrientedRect MinAreaRectangle(std::vector<glm::dvec2> points) {
  if (points.empty()) return {};
  const std::vector<glm::dvec2> hull = ConvexHull(std::move(points));
  // Candidates: the bounds along each hull edge (and the plane's own axes),
  // the edge's direction folded into [-45, 45) degrees (the same rectangle
  // up to a quarter or half turn).
  std::vector<OrientedRect> candidates;
  candidates.push_back(BoundsAlong(hull, glm::dvec2(1.0, 0.0)));
  for (size_t i = 0; i < hull.size() && hull.size() >= 2; ++i) {
    glm::dvec2 edge = hull[(i + 1) % hull.size()] - hull[i];
    const double len = glm::length(edge);
    if (!(len > 0.0)) continue;
    edge /= len;
    while (!(edge.x > 0.0 && std::abs(edge.y) <= edge.x)) edge = glm::dvec2(edge.y, -edge.x);  // quarter turns
    candidates.push_back(BoundsAlong(hull, edge));
  }
  // The smallest area up to a relative tolerance far above the rounding of
  // float vertices (ties: a regular polygon's edges, a rectangle's four
  // sides), then among those the direction nearest the plane's u axis, then
  // the one turned counter-clockwise: the same rectangle whatever the units.
  constexpr double kTie = 1e-4;
  double smallest = HUGE_VAL;
  for (const OrientedRect& r : candidates) smallest = std::min(smallest, r.extent.x * r.extent.y);
  OrientedRect best;
  bool have = false;
  for (const OrientedRect& r : candidates) {
    if (!(r.extent.x * r.extent.y <= smallest * (1.0 + kTie) + 1e-300)) continue;
    const double angle = std::atan2(r.axis_x.y, r.axis_x.x);
    const double best_angle = std::atan2(best.axis_x.y, best.axis_x.x);
    if (!have || std::abs(angle) < std::abs(best_angle) - kTie ||
        (std::abs(angle) <= std::abs(best_angle) + kTie && angle > best_angle + kTie)) {
      best = r;
      have = true;
    }
  }
  if (best.extent.x < best.extent.y * (1.0 - kTie)) {
    // Quarter turn: (x, y) -> (y, -x) keeps the determinant at +1.
    OrientedRect turned;
    turned.axis_x = best.axis_y;
    turned.axis_y = -best.axis_x;
    turned.min = glm::dvec2(best.min.y, -(best.min.x + best.extent.x));
    turned.extent = glm::dvec2(best.extent.y, best.extent.x);
    best = turned;
  }
  return best;
}

absl::StatusOr<PackedLayout> PackCharts(const std::vector<ChartShape>& charts, int size, int gutter) {
  // Decreasing box area in size classes (SizeClass): charts equal up to
  // rounding keep their index order whatever the mesh's units. (Measured on
  // samba: by box area 0.583 / 0.614 coverage at 512 / 1024, by chart area
  // 0.577 / 0.612, by longest side 0.557 / 0.576.)
  double largest_box = 0.0, total_area = 0.0, longest = 0.0;
  for (const ChartShape& c : charts) {
    largest_box = std::max(largest_box, c.extent.x * c.extent.y);
    total_area += c.area;
    longest = std::max(longest, c.extent.x);
  }
  std::vector<std::pair<int, size_t>> keyed;
  keyed.reserve(charts.size());
  for (size_t i = 0; i < charts.size(); ++i) {
    keyed.emplace_back(-SizeClass(charts[i].extent.x * charts[i].extent.y, largest_box), i);
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<size_t> order(charts.size());
  for (size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  PackedLayout layout;
  if (!PackAt(charts, order, 0.0, size, gutter, &layout)) {
    return absl::ResourceExhaustedError(absl::StrCat("atlas of ", size, " x ", size, " texels with a gutter of ",
                                                     gutter, " cannot hold ", charts.size(),
                                                     " charts even at one texel each; use a larger atlas (--atlas)"));
  }
  // Upper bounds on the scale: the charts' area, s^2 sum(area) <= inner^2,
  // and the longest side, s w <= inner, for the inner square of side
  // size - 2 gutter.
  const double inner = size - 2.0 * gutter;
  double hi = total_area > 0.0 ? inner / std::sqrt(total_area) : HUGE_VAL;
  if (longest > 0.0) hi = std::min(hi, inner / longest);
  if (!(hi < HUGE_VAL)) return layout;  // every chart is a point: any scale
  double lo = 0.0;
  PackedLayout trial;
  while (hi - lo > 1e-3 * hi) {
    const double mid = 0.5 * (lo + hi);
    if (PackAt(charts, order, mid, size, gutter, &trial)) {
      lo = mid;
      layout = trial;
    } else {
      hi = mid;
    }
  }
  return layout;
}

int BoxTexels(double extent, double texels_per_unit) {
  return std::max(1, static_cast<int>(std::ceil(extent * texels_per_unit)));
}

glm::dvec2 PackedLayout::Place(size_t i, const glm::dvec2& extent, const glm::dvec2& q) const {
  const glm::dvec2 t = texels_per_unit * q;
  const double w = BoxTexels(extent.x, texels_per_unit), h = BoxTexels(extent.y, texels_per_unit);
  glm::dvec2 turned = t;
  switch (turns[i]) {
    case 1:
      turned = glm::dvec2(h - t.y, t.x);
      break;
    case 2:
      turned = glm::dvec2(w - t.x, h - t.y);
      break;
    case 3:
      turned = glm::dvec2(t.y, w - t.x);
      break;
    default:
      break;
  }
  return glm::dvec2(offsets[i]) + turned;
}

}  // namespace mvbrdf::atlas::internal
