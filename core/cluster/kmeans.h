// Clustering texels into materials (thesis §6.2.1): k-means on each texel's
// average linear reflectance, seeded with the scene's material seeds
// (8-bit sRGB, linearised) or, without seeds, with k chosen automatically.
// Per-segment material lists restrict which clusters a texel may join
// (thesis: "only skin and hair in the skull segment").
#ifndef MVBRDF_CORE_CLUSTER_KMEANS_H_
#define MVBRDF_CORE_CLUSTER_KMEANS_H_

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "absl/status/statusor.h"

namespace mvbrdf::cluster {

struct KMeansOptions {
  // Seeds in linear RGB; empty: automatic (k from 1..max_automatic_k by the
  // criterion documented in kmeans.cc, k-means++ initialisation, fixed seed).
  std::vector<glm::vec3> seeds;
  std::vector<std::string> seed_names;
  int max_automatic_k = 6;
  int max_iterations = 100;
  // Stop when fewer than this share of points change cluster (thesis: "until
  // the change in the number of samples in each cluster is very small").
  double min_change_fraction = 1e-4;
  uint32_t random_seed = 1;
};

struct KMeansInput {
  std::vector<glm::vec3> points;  // per texel: average linear reflectance
  std::vector<float> weights;     // per texel (e.g. its sample count); empty = 1
  // Optional: per point, a segment index, and per segment the clusters
  // (indices into the seeds) allowed in it; empty = all allowed everywhere.
  std::vector<uint32_t> segment;
  std::vector<std::vector<uint32_t>> allowed_clusters;
};

struct KMeansResult {
  std::vector<glm::vec3> centres;
  std::vector<std::string> names;   // seed names, or "cluster N"
  std::vector<uint32_t> assignment; // per point
  std::vector<uint64_t> sizes;
  int iterations = 0;
  double inertia = 0.0;             // weighted sum of squared distances
  bool automatic_k = false;
};

absl::StatusOr<KMeansResult> KMeans(const KMeansInput& input, const KMeansOptions& options);

// Clusters too small to be a material: fewer points than
// max(kMinMaterialPoints, kMinMaterialShare of all points). Automatic k can
// give a handful of outlier texels (a few badly lit ones, albedo estimates
// far off) a cluster of their own, whose BRDF fit is noise or fails for lack
// of data. MergeTinyClusters moves every point of such a cluster to the
// nearest (by its own distance) cluster that is not tiny, moves the centres
// that received points to the weighted mean of their points, and leaves the
// tiny clusters empty (size 0, centre kept). The largest cluster is never
// tiny. Returns per cluster whether it was merged.
inline constexpr uint64_t kMinMaterialPoints = 16;
inline constexpr double kMinMaterialShare = 0.005;
std::vector<bool> MergeTinyClusters(const KMeansInput& input, KMeansResult* result);

// KMeans, and with automatic k (no seeds) the tiny clusters' points left out
// of choosing k: outliers take splits that belong to materials (on a
// synthetic actor of three materials, two clusters of a few texels with
// albedo estimates in the thousands left one cluster for everything), or,
// when no chosen k isolates them, still add to every k's inertia (albedo
// estimates of 3-30 on 0.5 % of the texels kept one cluster). The outliers
// are the first run's tiny clusters or, where it has none, those of its run
// at the largest k tried. k and the centres are chosen again on the other
// points; the outliers then join their nearest cluster without moving its
// centre, and any cluster still tiny is merged (MergeTinyClusters). The
// outliers' clusters come last, empty, and `tiny` (per cluster) marks them
// and the merged ones. Seeded clusters are the scene's materials: as KMeans
// gives them, none tiny.
absl::StatusOr<KMeansResult> KMeansOfMaterials(const KMeansInput& input, const KMeansOptions& options,
                                               std::vector<bool>* tiny);

}  // namespace mvbrdf::cluster

#endif  // MVBRDF_CORE_CLUSTER_KMEANS_H_
