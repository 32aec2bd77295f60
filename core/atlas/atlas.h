// The texture atlas of a sequence (thesis §5.1): one 2D domain for the whole
// surface, fixed for every frame, so that each texel is one surface point over
// time.
//
// Image convention (shared by every atlas image in the project): an atlas is
// an image of `size` x `size` texels, row 0 at the top; texel (column i,
// row j) has its centre at u = (i + 0.5) / size, v = 1 - (j + 0.5) / size.
// (The same as the renderer's textures: row 0 is v = 1.)
#ifndef MVBRDF_CORE_ATLAS_ATLAS_H_
#define MVBRDF_CORE_ATLAS_ATLAS_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "core/scene/mesh.h"

namespace mvbrdf::atlas {

struct AtlasOptions {
  // Texels per side of the square atlas (e.g. 512, 1024).
  int size = 512;
  // Chart growth (meshes without UVs): a triangle joins a chart while the
  // angle between its normal and the chart's average normal stays below this.
  double max_normal_deviation_deg = 50.0;
  // Empty texels kept between charts (and at the atlas border), so that
  // growing (dilation) and bilinear lookups never mix charts.
  int gutter = 2;
  // Meshes with UVs: keep them (true) or build a new atlas anyway (false).
  bool keep_existing_uvs = true;

  absl::Status Check() const;
};

struct AtlasStats {
  bool built = false;  // false: the mesh's own UVs were kept
  int num_charts = 0;
  // Fraction of covered texels claimed by more than one triangle (texel
  // centres inside two triangles of different charts, or the same chart
  // folded): 0 for a valid atlas.
  double overlap_fraction = 0.0;
  // Fraction of the atlas's texels whose centre lies in some triangle.
  double coverage = 0.0;
  // Texel-area distortion: for each triangle, (UV area / surface area)
  // divided by the same ratio over the whole mesh; min and max over triangles
  // with non-zero area (1 = uniform sampling density).
  //
  // Bound for built atlases: every chart is an orthographic projection at one
  // global scale s, so a triangle at angle theta to its chart's plane normal
  // has UV area = s^2 cos(theta) x surface area, with theta <= d =
  // max_normal_deviation_deg. Dividing by the mesh's area-weighted mean of
  // cos(theta) (in [cos d, 1]) gives
  //   min_area_ratio >= cos d,  max_area_ratio <= 1 / cos d,
  //   max_area_ratio / min_area_ratio <= 1 / cos d,
  // up to the float rounding of UVs on the tiniest triangles (measured on
  // samba: see atlas_test.cc).
  double min_area_ratio = 0.0;
  double max_area_ratio = 0.0;
  // Triangles (non-zero area) with no texel centre inside; each is given the
  // texel under its UV centroid instead (see Atlas::triangle_texels).
  int triangles_without_interior_texels = 0;
  // Built atlases: the global scale, atlas texels per world unit of length on
  // the chart planes (sampling density); 0 when the mesh's UVs were kept.
  double texels_per_world_unit = 0.0;
};

struct Atlas {
  int size = 0;
  // The mesh with atlas UVs: same triangles over the same file vertices as
  // the input (file order), render vertices split where charts are cut.
  scene::MeshTopology topology;
  // Per triangle: its chart.
  std::vector<uint32_t> triangle_chart;
  // CV_32SC1 size x size: the triangle whose interior holds the texel centre,
  // or -1 (gutter, unused).
  cv::Mat triangle_id;
  // Per triangle: the texels (row * size + column) whose centre it holds; a
  // triangle holding none gets the texel under its UV centroid.
  std::vector<std::vector<uint32_t>> triangle_texels;
  AtlasStats stats;
};

// Builds the atlas from the rest pose (frame 0). Meshes with UVs keep them
// (checked: in range, overlap fraction reported; charts are the components
// connected over render-vertex edges); meshes without (or with
// keep_existing_uvs false) get charts grown from seed triangles by normal
// deviation, each projected orthogonally onto the plane of its average normal,
// split where the projection would overlap itself, turned to its minimal
// bounding rectangle, and the charts' outlines are packed (turned by quarter
// turns where that fits lower) with a gutter at the largest scale that fits.
// Built atlases keep triangle order and file_triangles; a file vertex used by k
// charts becomes k render vertices. Errors: options.Check(), inconsistent
// topology or positions (INVALID_ARGUMENT naming the field), too many charts
// for the atlas size (RESOURCE_EXHAUSTED). Pure function; any thread.
absl::StatusOr<Atlas> BuildAtlas(const scene::MeshTopology& topology, const scene::FramePositions& rest_positions,
                                 const AtlasOptions& options);

// Rasterises the triangles' UVs on the CPU (texel centres, half-open edge rule
// so that a centre on a shared edge belongs to exactly one triangle): fills
// atlas->triangle_id, atlas->triangle_texels and the overlap, coverage and
// interior-texel statistics. Requires atlas->size and atlas->topology.
void RasterizeTriangles(Atlas* atlas);

}  // namespace mvbrdf::atlas

#endif  // MVBRDF_CORE_ATLAS_ATLAS_H_
