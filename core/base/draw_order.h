// Random draws in a fixed order. C++ leaves the order in which a call's
// arguments are evaluated unspecified: glm::dvec3(n(rng), n(rng), n(rng))
// draws z first under GCC and x first under clang, so one seed gave different
// synthetic data with each compiler (scripts/test-sanitizers builds with
// clang). DrawVec3 draws last to first, GCC's order, in which this project's
// synthetic data and measured figures were made; a call with two drawn
// arguments draws the second one first for the same reason.
#ifndef MVBRDF_CORE_BASE_DRAW_ORDER_H_
#define MVBRDF_CORE_BASE_DRAW_ORDER_H_

namespace mvbrdf::base {

template <typename Vec, typename Draw>
Vec DrawVec3(Draw&& draw) {
  const auto z = draw();
  const auto y = draw();
  const auto x = draw();
  return Vec(x, y, z);
}

}  // namespace mvbrdf::base

#endif  // MVBRDF_CORE_BASE_DRAW_ORDER_H_
