// Minimal-area rectangles and the shelf packer with a binary search over the
// global scale.
#include "core/atlas/packing.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

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

// Box sides in whole texels (content rounded up, at least one texel).
int BoxTexels(double extent, double texels_per_unit) {
  return std::max(1, static_cast<int>(std::ceil(extent * texels_per_unit)));
}

// First-fit decreasing-height shelves. `order` sorts the rectangles by
// decreasing height, so a shelf's first box is its tallest. Fills `offsets`
// and returns true when everything fits.
bool PackShelves(const std::vector<glm::dvec2>& extents, const std::vector<size_t>& order, double texels_per_unit,
                 int size, int gutter, std::vector<glm::ivec2>* offsets) {
  struct Shelf {
    int y, height, x;  // x: next free column
  };
  std::vector<Shelf> shelves;
  int top = gutter;  // first row above the shelves so far
  offsets->assign(extents.size(), glm::ivec2(0));
  for (size_t i : order) {
    // Each box carries the gutter on its right and top; the atlas's first
    // `gutter` rows and columns are the border on the other sides.
    const int w = BoxTexels(extents[i].x, texels_per_unit) + gutter;
    const int h = BoxTexels(extents[i].y, texels_per_unit) + gutter;
    if (w > size - gutter) return false;
    bool placed = false;
    for (Shelf& shelf : shelves) {
      if (h <= shelf.height && shelf.x + w <= size) {
        (*offsets)[i] = glm::ivec2(shelf.x, shelf.y);
        shelf.x += w;
        placed = true;
        break;
      }
    }
    if (placed) continue;
    if (top + h > size) return false;
    shelves.push_back({top, h, gutter + w});
    (*offsets)[i] = glm::ivec2(gutter, top);
    top += h;
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

absl::StatusOr<PackedLayout> PackRectangles(const std::vector<glm::dvec2>& extents, int size, int gutter) {
  // Decreasing height, then width, in size classes (SizeClass): charts equal
  // up to rounding keep their index order whatever the mesh's units.
  glm::dvec2 largest(0.0);
  for (const glm::dvec2& e : extents) largest = glm::max(largest, e);
  std::vector<std::tuple<int, int, size_t>> keyed;
  keyed.reserve(extents.size());
  for (size_t i = 0; i < extents.size(); ++i) {
    keyed.emplace_back(-SizeClass(extents[i].y, largest.y), -SizeClass(extents[i].x, largest.x), i);
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<size_t> order(extents.size());
  for (size_t i = 0; i < keyed.size(); ++i) order[i] = std::get<2>(keyed[i]);
  PackedLayout layout;
  if (!PackShelves(extents, order, 0.0, size, gutter, &layout.offsets)) {
    return absl::ResourceExhaustedError(absl::StrCat("atlas of ", size, " x ", size, " texels with a gutter of ",
                                                     gutter, " cannot hold ", extents.size(),
                                                     " charts even at one texel each; use a larger atlas (--atlas)"));
  }
  // The content area bounds the scale from above: sum (s w)(s h) <= size^2.
  double content = 0.0;
  double longest = 0.0;
  for (const glm::dvec2& e : extents) {
    content += e.x * e.y;
    longest = std::max(longest, e.x);
  }
  // So does the longest side: s w <= size.
  double hi = content > 0.0 ? size / std::sqrt(content) : HUGE_VAL;
  if (longest > 0.0) hi = std::min(hi, static_cast<double>(size) / longest);
  if (!(hi < HUGE_VAL)) return layout;  // every chart is a point: any scale
  double lo = 0.0;
  std::vector<glm::ivec2> offsets;
  while (hi - lo > 1e-4 * hi) {
    const double mid = 0.5 * (lo + hi);
    if (PackShelves(extents, order, mid, size, gutter, &offsets)) {
      lo = mid;
      layout.offsets = offsets;
    } else {
      hi = mid;
    }
  }
  layout.texels_per_unit = lo;
  return layout;
}

}  // namespace mvbrdf::atlas::internal
