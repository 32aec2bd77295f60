// Texel adjacency on the surface (issue #14 item 5): which atlas texels are
// neighbours on the mesh, for smoothing per-texel labels (the clusters) over
// the surface rather than over the atlas image.
#ifndef MVBRDF_CORE_ATLAS_TEXEL_GRAPH_H_
#define MVBRDF_CORE_ATLAS_TEXEL_GRAPH_H_

#include <cstdint>
#include <utility>
#include <vector>

#include "core/atlas/atlas.h"

namespace mvbrdf::atlas {

struct TexelEdges {
  // Unordered pairs (a < b) of texels (row * size + column), each once,
  // sorted. Both texels are covered (atlas.triangle_id >= 0).
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  uint64_t chart_edges = 0;  // 4-neighbours inside one chart
  uint64_t seam_edges = 0;   // across a UV seam (one mesh edge, two places in the atlas)
};

// Two kinds of neighbour:
// - inside a chart: 4-neighbours in the atlas whose triangles lie in the same
//   chart, the components of the triangles connected over render-vertex
//   edges (a chart's UVs are continuous, so its atlas neighbours are surface
//   neighbours; texels of two charts packed side by side are not);
// - across a seam: for each mesh edge (over file vertices) whose two
//   triangles do not share its render vertices, points spaced at most one
//   texel apart along the edge in each triangle's UVs, and at each point the
//   texel of that triangle nearest to it, paired with the other side's.
// Requires atlas.size, atlas.topology (with UVs), atlas.triangle_id and
// atlas.triangle_texels (BuildAtlas gives them). Pure function; any thread.
TexelEdges BuildTexelEdges(const Atlas& atlas);

}  // namespace mvbrdf::atlas

#endif  // MVBRDF_CORE_ATLAS_TEXEL_GRAPH_H_
