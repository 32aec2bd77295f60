// Chart layout in the atlas: each chart's projection is turned to its
// minimal-area bounding rectangle, and the charts' outlines (the texels their
// triangles touch) are packed into the square atlas at one global scale
// (texels per world unit), the largest that fits, so that every chart is
// sampled equally densely. Internal to
// mvbrdf_atlas (used by BuildAtlas, exposed for tests).
#ifndef MVBRDF_CORE_ATLAS_PACKING_H_
#define MVBRDF_CORE_ATLAS_PACKING_H_

#include <array>
#include <glm/glm.hpp>
#include <vector>

#include "absl/status/statusor.h"

namespace mvbrdf::atlas::internal {

// A rotation of the plane and the box it bounds: a point p (chart plane, world
// units) maps to rect_from_plane(p) = (dot(p, axis_x), dot(p, axis_y)) - min,
// which lies in [0, extent.x] x [0, extent.y]. (axis_x, axis_y) is a rotation
// (determinant +1), so orientation is kept; extent.x >= extent.y.
struct OrientedRect {
  glm::dvec2 axis_x{1.0, 0.0};
  glm::dvec2 axis_y{0.0, 1.0};
  glm::dvec2 min{0.0};
  glm::dvec2 extent{0.0};

  glm::dvec2 RectFromPlane(const glm::dvec2& p) const {
    return glm::dvec2(glm::dot(p, axis_x), glm::dot(p, axis_y)) - min;
  }
};

// The bounding rectangle of minimal area (one side is collinear with a convex
// hull edge; rotating calipers over the hull, O(h^2) for h hull points), turned
// to landscape. Empty input gives the zero rectangle.
OrientedRect MinAreaRectangle(std::vector<glm::dvec2> points);

// A chart as the packer sees it: its triangles in its minimal rectangle's
// frame (OrientedRect::RectFromPlane, world units), inside
// [0, extent.x] x [0, extent.y], and its area (world units^2).
struct ChartShape {
  glm::dvec2 extent{0.0};
  std::vector<std::array<glm::dvec2, 3>> triangles;
  double area = 0.0;
};

// The packing of chart outlines into a size x size atlas (issue #17: packing
// rectangles left ~0.57 of a samba atlas's rectangles empty).
//
// Texel frame: x right, y up, in texels, the atlas is [0, size]^2 (so that
// u = x / size, v = y / size). Chart i is scaled by `texels_per_unit` into its
// box of Box(i) = max(1, ceil(texels_per_unit * extent)) texels per side,
// turned by `turns[i]` quarter turns counter-clockwise inside its box (the box
// turns with it; Place gives the exact map) and its box put at `offsets[i]`,
// a texel corner. The texels any of a chart's triangles touches (closed
// triangle, closed texel square) are its footprint; footprints keep more than
// `gutter` texels between each other in x or y (Chebyshev distance), and
// boxes stay `gutter` whole texels inside the atlas border, as rectangles'
// boxes did.
struct PackedLayout {
  double texels_per_unit = 0.0;
  std::vector<glm::ivec2> offsets;
  std::vector<int> turns;

  // Texel position of the rect-frame point q of chart `i` with `extent`.
  glm::dvec2 Place(size_t i, const glm::dvec2& extent, const glm::dvec2& q) const;
};

// Box side in whole texels: the content rounded up, at least one texel.
int BoxTexels(double extent, double texels_per_unit);

// Largest scale (bisection, to 1e-3 relative) at which a bottom-left packer
// fits every chart's footprint: charts by decreasing box area, each in the
// turn and place where its footprint grown by the gutter meets no footprint
// placed before and its box's top is lowest (then its row, then column). RESOURCE_EXHAUSTED when even 1-texel charts do
// not fit. Deterministic; the same layout whatever the mesh's units up to
// rounding on texel boundaries.
absl::StatusOr<PackedLayout> PackCharts(const std::vector<ChartShape>& charts, int size, int gutter);

}  // namespace mvbrdf::atlas::internal

#endif  // MVBRDF_CORE_ATLAS_PACKING_H_
