// A reconstruction as Wavefront OBJ + MTL (issue #16): the thesis's model's
// native exchange format, `mvbrdf export RUN --out model.obj`.
//
// MODEL.obj holds the mesh with the atlas UVs and smooth normals (the rest pose
// or frame T); MODEL.mtl one material whose maps are MODEL_Kd.png (sRGB),
// MODEL_Ks.png (sRGB) and MODEL_Ns.png (16-bit grey, x Ns 10000), in classic
// Phong's sense L = I (Kd n.l + Ks (R.v)^Ns): the thesis's model itself, so a
// Phong run is exact (up to 8-bit maps), and other models' lobes pass through
// brdf::PhongEquivalent (same head-on peak, the width rule). One scale s
// brings Kd and Ks into [0, 1] (the 99.9th percentile of the observed texels;
// brighter ones clip), written in the MTL's header: lights x 1 / s give the
// run's radiance.
#ifndef MVBRDF_CORE_EXPORT_OBJ_EXPORT_H_
#define MVBRDF_CORE_EXPORT_OBJ_EXPORT_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/scene/sequence.h"

namespace mvbrdf::exporter {

struct ObjExportSummary {
  double scale = 1.0;
  int vertices = 0, triangles = 0;
  double clipped_fraction = 0.0;  // observed texels whose Kd or Ks clipped at 1
  std::vector<std::filesystem::path> files;  // written, the OBJ first
};

// `out` ends in .obj; the MTL and maps are written beside it, named by its
// stem. `frame`: -1 the rest pose, else a frame of the sequence.
absl::StatusOr<ObjExportSummary> ExportObj(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                           const std::filesystem::path& out, int frame);

}  // namespace mvbrdf::exporter

#endif  // MVBRDF_CORE_EXPORT_OBJ_EXPORT_H_
