// The atlas's figures as reports carry them (resample.json, result.json).
#ifndef MVBRDF_CORE_PIPELINE_ATLAS_FIGURES_H_
#define MVBRDF_CORE_PIPELINE_ATLAS_FIGURES_H_

#include "core/atlas/atlas.h"
#include "mvbrdf/v1/resample_report.pb.h"

namespace mvbrdf::pipeline {

inline void SetAtlasFigures(const atlas::Atlas& atlas, double seconds, v1::AtlasFigures* f) {
  f->set_size(static_cast<uint32_t>(atlas.size));
  f->set_built(atlas.stats.built);
  f->set_charts(static_cast<uint32_t>(atlas.stats.num_charts));
  f->set_coverage(atlas.stats.coverage);
  f->set_overlap_fraction(atlas.stats.overlap_fraction);
  f->set_min_area_ratio(atlas.stats.min_area_ratio);
  f->set_max_area_ratio(atlas.stats.max_area_ratio);
  f->set_triangles_without_interior_texels(static_cast<uint32_t>(atlas.stats.triangles_without_interior_texels));
  f->set_seconds(seconds);
}

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_ATLAS_FIGURES_H_
