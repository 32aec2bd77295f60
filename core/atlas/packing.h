// Chart layout in the atlas: each chart's projection is turned to its
// minimal-area bounding rectangle, and the rectangles are packed into the
// square atlas at one global scale (texels per world unit), the largest that
// fits, so that every chart is sampled equally densely. Internal to
// mvbrdf_atlas (used by BuildAtlas, exposed for tests).
#ifndef MVBRDF_CORE_ATLAS_PACKING_H_
#define MVBRDF_CORE_ATLAS_PACKING_H_

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

// The packing of rectangles into a size x size atlas.
//
// Texel frame: x right, y up, in texels, the atlas is [0, size]^2 (so that
// u = x / size, v = y / size). Rectangle i, scaled by `texels_per_unit`, is
// placed at [offsets[i], offsets[i] + texels_per_unit * extents[i]]; its box
// of max(1, ceil(texels_per_unit * extent)) texels per side starts on a texel
// boundary, and boxes keep `gutter` whole texels between each other and
// between themselves and the atlas border.
struct PackedLayout {
  double texels_per_unit = 0.0;
  std::vector<glm::ivec2> offsets;
};

// Largest scale (binary search, to 1e-4 relative) at which a first-fit shelf
// packer, with rectangles sorted by decreasing height, fits all of them.
// RESOURCE_EXHAUSTED when even 1-texel boxes do not fit.
absl::StatusOr<PackedLayout> PackRectangles(const std::vector<glm::dvec2>& extents, int size, int gutter);

}  // namespace mvbrdf::atlas::internal

#endif  // MVBRDF_CORE_ATLAS_PACKING_H_
