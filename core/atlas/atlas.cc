// BuildAtlas: keep a mesh's UVs or build charts, lay them out and rasterise.
#include "core/atlas/atlas.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/atlas/charts.h"
#include "core/atlas/packing.h"
#include "core/base/status_macros.h"

namespace mvbrdf::atlas {
namespace {

using internal::Chart;
using internal::TriangleGeometry;

absl::Status CheckRange(const char* field, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": must be in [", lo, ", ", hi, "], got ", value));
  }
  return absl::OkStatus();
}

std::string TriangleField(const char* array, size_t t) { return absl::StrCat("topology.", array, "[", t, "]"); }

// The topology's arrays agree with each other and with the rest pose.
absl::Status CheckInput(const scene::MeshTopology& topo, const scene::FramePositions& positions, bool need_uvs) {
  if (topo.triangles.empty()) return absl::InvalidArgumentError("topology.triangles: mesh has no triangles");
  if (topo.file_triangles.size() != topo.triangles.size()) {
    return absl::InvalidArgumentError(absl::StrCat("topology.file_triangles: expected ", topo.triangles.size(),
                                                   " triangles (as topology.triangles), got ",
                                                   topo.file_triangles.size()));
  }
  if (positions.size() != topo.num_file_vertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("rest_positions: expected ", topo.num_file_vertices, " file vertices, got ", positions.size()));
  }
  for (size_t i = 0; i < positions.size(); ++i) {
    const glm::vec3& p = positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return absl::InvalidArgumentError(absl::StrCat("rest_positions[", i, "]: not finite"));
    }
  }
  for (size_t r = 0; r < topo.render_to_file_vertex.size(); ++r) {
    if (topo.render_to_file_vertex[r] >= topo.num_file_vertices) {
      return absl::InvalidArgumentError(absl::StrCat("topology.render_to_file_vertex[", r,
                                                     "]: ", topo.render_to_file_vertex[r], " is not a file vertex (",
                                                     topo.num_file_vertices, ")"));
    }
  }
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (topo.file_triangles[t][k] >= topo.num_file_vertices) {
        return absl::InvalidArgumentError(absl::StrCat(TriangleField("file_triangles", t), ": vertex ",
                                                       topo.file_triangles[t][k], " out of range (",
                                                       topo.num_file_vertices, " file vertices)"));
      }
      if (topo.triangles[t][k] >= topo.num_render_vertices()) {
        return absl::InvalidArgumentError(absl::StrCat(TriangleField("triangles", t), ": vertex ", topo.triangles[t][k],
                                                       " out of range (", topo.num_render_vertices(),
                                                       " render vertices)"));
      }
      if (topo.render_to_file_vertex[topo.triangles[t][k]] != topo.file_triangles[t][k]) {
        return absl::InvalidArgumentError(absl::StrCat(TriangleField("triangles", t), ": render vertex ",
                                                       topo.triangles[t][k], " is not on file vertex ",
                                                       topo.file_triangles[t][k], " of topology.file_triangles"));
      }
    }
  }
  for (uint32_t t : topo.zero_area_triangles) {
    if (t >= topo.triangles.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("topology.zero_area_triangles: ", t, " is not a triangle (", topo.triangles.size(), ")"));
    }
  }
  if (need_uvs) {
    if (topo.uvs.size() != topo.num_render_vertices()) {
      return absl::InvalidArgumentError(absl::StrCat("topology.uvs: expected ", topo.num_render_vertices(),
                                                     " (one per render vertex), got ", topo.uvs.size()));
    }
    for (size_t r = 0; r < topo.uvs.size(); ++r) {
      const glm::vec2& uv = topo.uvs[r];
      if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f)) {
        return absl::InvalidArgumentError(
            absl::StrCat("topology.uvs[", r, "]: must be in [0, 1]^2, got (", uv.x, ", ", uv.y, ")"));
      }
    }
  }
  return absl::OkStatus();
}

// Area ratios from the atlas's (float) UVs against the rest pose's surface.
void ComputeAreaRatios(const Atlas& atlas, const TriangleGeometry& geometry, AtlasStats* stats) {
  const scene::MeshTopology& topo = atlas.topology;
  std::vector<double> uv_area(topo.triangles.size(), 0.0);
  double uv_total = 0.0, surface_total = 0.0;
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    if (geometry.degenerate[t]) continue;
    const glm::dvec2 a(topo.uvs[topo.triangles[t].x]), b(topo.uvs[topo.triangles[t].y]),
        c(topo.uvs[topo.triangles[t].z]);
    uv_area[t] = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    uv_total += uv_area[t];
    surface_total += geometry.area[t];
  }
  stats->min_area_ratio = 0.0;
  stats->max_area_ratio = 0.0;
  if (!(uv_total > 0.0 && surface_total > 0.0)) return;
  const double global = uv_total / surface_total;
  double lo = HUGE_VAL, hi = 0.0;
  for (size_t t = 0; t < topo.triangles.size(); ++t) {
    if (geometry.degenerate[t]) continue;
    const double ratio = uv_area[t] / geometry.area[t] / global;
    lo = std::min(lo, ratio);
    hi = std::max(hi, ratio);
  }
  stats->min_area_ratio = lo;
  stats->max_area_ratio = hi;
}

// The mesh's own UVs: charts are the UV-connected components.
Atlas KeepUvs(const scene::MeshTopology& topology, int size) {
  Atlas atlas;
  atlas.size = size;
  atlas.topology = topology;
  const internal::TriangleAdjacency adjacency = internal::BuildEdgeAdjacency(topology.triangles);
  atlas.stats.num_charts = internal::ConnectedComponents(adjacency, &atlas.triangle_chart);
  return atlas;
}

// New charts, split render vertices and packed UVs.
absl::StatusOr<Atlas> BuildCharts(const scene::MeshTopology& input, const scene::FramePositions& positions,
                                  const TriangleGeometry& geometry, const AtlasOptions& options) {
  const size_t num_triangles = input.triangles.size();
  const internal::TriangleAdjacency adjacency = internal::BuildEdgeAdjacency(input.file_triangles);
  const std::vector<Chart> charts =
      internal::BuildCharts(input, positions, geometry, adjacency, options.max_normal_deviation_deg);

  Atlas atlas;
  atlas.size = options.size;
  atlas.triangle_chart.assign(num_triangles, 0);
  for (size_t c = 0; c < charts.size(); ++c) {
    for (uint32_t t : charts[c].triangles) atlas.triangle_chart[t] = static_cast<uint32_t>(c);
  }

  // Render vertices: one per (file vertex, chart), numbered in order of first
  // use by the triangles (as LoadMesh numbers them).
  scene::MeshTopology& topo = atlas.topology;
  topo.file_triangles = input.file_triangles;
  topo.num_file_vertices = input.num_file_vertices;
  topo.zero_area_triangles = input.zero_area_triangles;
  topo.triangles.resize(num_triangles);
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> renders_of_file(input.num_file_vertices);  // (chart, render)
  std::vector<uint32_t> render_chart;
  for (size_t t = 0; t < num_triangles; ++t) {
    const uint32_t c = atlas.triangle_chart[t];
    for (int k = 0; k < 3; ++k) {
      const uint32_t f = input.file_triangles[t][k];
      auto& renders = renders_of_file[f];
      auto it = std::find_if(renders.begin(), renders.end(), [c](const auto& cr) { return cr.first == c; });
      if (it == renders.end()) {
        renders.emplace_back(c, static_cast<uint32_t>(topo.render_to_file_vertex.size()));
        it = renders.end() - 1;
        topo.render_to_file_vertex.push_back(f);
        render_chart.push_back(c);
      }
      topo.triangles[t][k] = it->second;
    }
  }

  // Plane coordinates of every render vertex in its chart, then each chart's
  // minimal rectangle.
  const size_t num_render = topo.render_to_file_vertex.size();
  std::vector<glm::dvec2> plane(num_render);
  std::vector<std::vector<glm::dvec2>> chart_points(charts.size());
  for (size_t r = 0; r < num_render; ++r) {
    plane[r] = charts[render_chart[r]].Project(glm::dvec3(positions[topo.render_to_file_vertex[r]]));
    chart_points[render_chart[r]].push_back(plane[r]);
  }
  std::vector<internal::OrientedRect> rects(charts.size());
  std::vector<internal::ChartShape> shapes(charts.size());
  for (size_t c = 0; c < charts.size(); ++c) {
    rects[c] = internal::MinAreaRectangle(std::move(chart_points[c]));
    shapes[c].extent = rects[c].extent;
    shapes[c].triangles.reserve(charts[c].triangles.size());
    for (uint32_t t : charts[c].triangles) {
      std::array<glm::dvec2, 3> q;
      for (int k = 0; k < 3; ++k) q[k] = rects[c].RectFromPlane(plane[topo.triangles[t][k]]);
      shapes[c].triangles.push_back(q);
      shapes[c].area += 0.5 * std::abs((q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[1].y - q[0].y) * (q[2].x - q[0].x));
    }
  }
  MVBRDF_ASSIGN_OR_RETURN(const internal::PackedLayout layout,
                          internal::PackCharts(shapes, options.size, options.gutter));

  // Texel frame (x right, y up, texels) to UV: divide by the size.
  topo.uvs.resize(num_render);
  const double inv_size = 1.0 / options.size;
  for (size_t r = 0; r < num_render; ++r) {
    const uint32_t c = render_chart[r];
    const glm::dvec2 texel = layout.Place(c, rects[c].extent, rects[c].RectFromPlane(plane[r]));
    topo.uvs[r] = glm::vec2(texel * inv_size);
  }
  atlas.stats.built = true;
  atlas.stats.num_charts = static_cast<int>(charts.size());
  atlas.stats.texels_per_world_unit = layout.texels_per_unit;
  return atlas;
}

}  // namespace

absl::Status AtlasOptions::Check() const {
  MVBRDF_RETURN_IF_ERROR(CheckRange("AtlasOptions.size", size, 16, 16384));
  MVBRDF_RETURN_IF_ERROR(CheckRange("AtlasOptions.max_normal_deviation_deg", max_normal_deviation_deg, 1.0, 89.0));
  MVBRDF_RETURN_IF_ERROR(CheckRange("AtlasOptions.gutter", gutter, 0, size / 8));
  return absl::OkStatus();
}

absl::StatusOr<Atlas> BuildAtlas(const scene::MeshTopology& topology, const scene::FramePositions& rest_positions,
                                 const AtlasOptions& options) {
  MVBRDF_RETURN_IF_ERROR(options.Check());
  const bool keep = topology.has_uvs() && options.keep_existing_uvs;
  MVBRDF_RETURN_IF_ERROR(CheckInput(topology, rest_positions, keep));
  const TriangleGeometry geometry = internal::ComputeTriangleGeometry(topology, rest_positions);
  Atlas atlas;
  if (keep) {
    atlas = KeepUvs(topology, options.size);
  } else {
    MVBRDF_ASSIGN_OR_RETURN(atlas, BuildCharts(topology, rest_positions, geometry, options));
  }
  RasterizeTriangles(&atlas);
  ComputeAreaRatios(atlas, geometry, &atlas.stats);
  return atlas;
}

}  // namespace mvbrdf::atlas
