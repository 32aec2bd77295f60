// The passes' folds over an atlas in parts: its rows split into kAtlasParts
// ranges, each visited on a thread of its own (InAtlasParts), with whatever
// they sum over texels kept per part and added in part order. A fixed count,
// not the machine's, so that those sums do not depend on the machine. On 2
// cores the folds run while llvmpipe's threads wait for the next draw.
#ifndef MVBRDF_CORE_PIPELINE_ATLAS_PARTS_H_
#define MVBRDF_CORE_PIPELINE_ATLAS_PARTS_H_

#include <cstdint>
#include <thread>
#include <vector>

#include "core/samples/assemble.h"

namespace mvbrdf::pipeline {

inline constexpr int kAtlasParts = 2;

// Part `part`'s rows of an atlas of `size` rows.
inline samples::TexelRows AtlasPartRows(int part, int size) {
  return {static_cast<int>(static_cast<int64_t>(size) * part / kAtlasParts),
          static_cast<int>(static_cast<int64_t>(size) * (part + 1) / kAtlasParts)};
}

// work(part) for every part: part 0 on this thread, the others on their own.
template <typename F>
void InAtlasParts(F&& work) {
  std::vector<std::thread> others;
  for (int p = 1; p < kAtlasParts; ++p) others.emplace_back(work, p);
  work(0);
  for (std::thread& t : others) t.join();
}

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_ATLAS_PARTS_H_
