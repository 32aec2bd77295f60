// Spatial coherence of the clusters (issue #14 item 5): a Potts Markov random
// field over the texels' cluster labels on the surface, solved by alpha-expansion
// (graph cuts) from the plain nearest-centre labels.
//
// Energy: sum over points of D_i(l_i) + smoothness x (number of neighbour
// pairs with different labels), with the data cost
//   D_i(k) = (w_i / mean w) |x_i - c_k|^2 / s,
// s the median over the points of the same at their own (initial) label: the
// data cost of a typical point is 1 whatever the units of x and w, so
// `smoothness` is unit-free (the price of one unlike neighbour in typical
// squared distances to one's own centre). A point may only take a label its
// segment allows (KMeansInput::segment, allowed_clusters), and only labels
// some point has at the start (an empty cluster stays empty). Each iteration
// is one cycle of expansion moves over the labels, each the best labelling in
// which any point may switch to that label (a minimum cut, Boykov, Veksler
// and Zabih 2001); it stops when a cycle lowers the energy by a millionth or
// less. Unlike iterated conditional modes (one point at a time), a move can
// flip a whole wrongly labelled patch whose border costs more than its data.
#ifndef MVBRDF_CORE_CLUSTER_LABEL_SMOOTHING_H_
#define MVBRDF_CORE_CLUSTER_LABEL_SMOOTHING_H_

#include <cstdint>
#include <glm/glm.hpp>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/cluster/kmeans.h"

namespace mvbrdf::cluster {

struct LabelSmoothingOptions {
  double smoothness = 0.0;  // >= 0; 0: labels returned unchanged
  int max_iterations = 20;  // expansion cycles
};

struct LabelSmoothingResult {
  std::vector<uint32_t> labels;  // per point
  uint64_t relabelled = 0;       // points whose label differs from the input's
  int iterations = 0;            // expansion cycles run
  double data_scale = 0.0;       // s above, in the units of w |x|^2 / mean w
};

// `input`'s points, weights and segments; `centres` per cluster; `labels` per
// point (the clustering's); `edges` pairs of point indices (neighbours, each
// pair once; weight 1). Errors (INVALID_ARGUMENT): sizes that do not match,
// a label or an edge out of range, a negative or non-finite smoothness.
absl::StatusOr<LabelSmoothingResult> SmoothLabels(const KMeansInput& input, const std::vector<glm::vec3>& centres,
                                                  const std::vector<uint32_t>& labels,
                                                  const std::vector<std::pair<uint32_t, uint32_t>>& edges,
                                                  const LabelSmoothingOptions& options);

}  // namespace mvbrdf::cluster

#endif  // MVBRDF_CORE_CLUSTER_LABEL_SMOOTHING_H_
