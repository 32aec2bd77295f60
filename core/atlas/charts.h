// Chart construction for meshes without UVs (thesis §5.1): the surface is cut
// into charts whose triangles all face roughly the same way, so that each
// chart can be projected orthogonally onto one plane without folding and with
// bounded area distortion. Internal to mvbrdf_atlas (used by BuildAtlas,
// exposed for tests).
//
// Frames: positions are the rest pose in world units; a chart's plane
// coordinates are (dot(p - origin, axis_u), dot(p - origin, axis_v)) in the
// same world units, with (axis_u, axis_v, normal) right-handed, so that a
// triangle that is counter-clockwise seen from outside stays counter-clockwise
// in the plane.
#ifndef MVBRDF_CORE_ATLAS_CHARTS_H_
#define MVBRDF_CORE_ATLAS_CHARTS_H_

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "core/scene/mesh.h"

namespace mvbrdf::atlas::internal {

// Per triangle rest-pose geometry in double precision.
struct TriangleGeometry {
  std::vector<glm::dvec3> normal;  // unit; (0,0,0) when degenerate
  std::vector<double> area;        // world units^2
  // Listed in topology.zero_area_triangles, or no defined normal in double
  // precision: such triangles never seed or grow a chart; they are attached to
  // a neighbour's chart at the end (they claim no texel either way).
  std::vector<uint8_t> degenerate;
};

TriangleGeometry ComputeTriangleGeometry(const scene::MeshTopology& topology,
                                         const scene::FramePositions& rest_positions);

// Edge adjacency of triangles given as vertex-index triples (file or render
// vertices): triangles sharing an unordered vertex pair are neighbours. CSR
// layout: the neighbours of triangle t are neighbors[offsets[t] .. offsets[t+1]).
// Non-manifold edges make every pair of their triangles neighbours.
struct TriangleAdjacency {
  std::vector<uint32_t> offsets;
  std::vector<uint32_t> neighbors;
};

TriangleAdjacency BuildEdgeAdjacency(const std::vector<glm::uvec3>& triangles);

// Connected components of the adjacency (component ids in order of the lowest
// triangle index). Returns the number of components.
int ConnectedComponents(const TriangleAdjacency& adjacency, std::vector<uint32_t>* component);

struct Chart {
  // Projection plane: unit normal and an orthonormal basis of the plane.
  glm::dvec3 normal{0.0, 0.0, 1.0};
  glm::dvec3 axis_u{1.0, 0.0, 0.0};
  glm::dvec3 axis_v{0.0, 1.0, 0.0};
  glm::dvec3 origin{0.0};  // any point near the chart (precision only)
  // Triangle indices; the non-degenerate ones are edge-connected over file
  // vertices, make an angle <= max_normal_deviation_deg with `normal`, and
  // their projections have positive area and pairwise disjoint interiors.
  std::vector<uint32_t> triangles;

  glm::dvec2 Project(const glm::dvec3& p) const { return {glm::dot(p - origin, axis_u), glm::dot(p - origin, axis_v)}; }
};

// Grows charts from seed triangles (largest remaining first) over file-vertex
// edge adjacency, adding a neighbour while its normal stays within
// `max_normal_deviation_deg` (< 90) of the chart's running area-weighted
// average normal; triangles that end up outside that cone of the final average
// are released to later charts. Charts of fewer than 8 triangles then hand
// their triangles to an edge-adjacent larger chart whose final normal accepts
// them (that normal is kept, so the bound holds). Each chart is then re-grown
// inside its own projection so that no two of its triangles overlap (a band
// around a cylinder, or a spiral, would otherwise land on itself) and that the
// result is edge-connected; what does not fit starts further charts on the
// same plane.
// Degenerate triangles join an edge-adjacent chart (or get one of their own).
// Deterministic for a given input.
std::vector<Chart> BuildCharts(const scene::MeshTopology& topology, const scene::FramePositions& rest_positions,
                               const TriangleGeometry& geometry, const TriangleAdjacency& file_adjacency,
                               double max_normal_deviation_deg);

// Sort key for "larger first" orders that must not depend on the mesh's units
// nor on the float rounding of its vertices: value / largest in sixteenths of
// an octave, rounded (round(16 log2), so that ratios of 1/2, 1/4, ... common on
// regular meshes sit mid-class, not on a boundary). Values equal up to
// rounding (the triangles of one ring of a lathe mesh, the charts of a
// symmetric mesh) share a key, so their order is the index order whatever the
// scale; 0 or less: the lowest key.
int SizeClass(double value, double largest);

// True when the interiors of two counter-clockwise 2D triangles overlap by
// more than `tolerance` (an edge-function value, i.e. a length^2): separating
// axis test over the six edges. Triangles that only share an edge or a
// vertex do not overlap.
bool TrianglesOverlap(const glm::dvec2 a[3], const glm::dvec2 b[3], double tolerance);

}  // namespace mvbrdf::atlas::internal

#endif  // MVBRDF_CORE_ATLAS_CHARTS_H_
