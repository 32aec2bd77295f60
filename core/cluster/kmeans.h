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

}  // namespace mvbrdf::cluster

#endif  // MVBRDF_CORE_CLUSTER_KMEANS_H_
