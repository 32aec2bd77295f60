// Status propagation helpers for absl::Status / absl::StatusOr at boundaries
// that can fail on input (I/O, parsing, EGL/GL set-up, SQLite, RPC).
#ifndef MVBRDF_CORE_BASE_STATUS_MACROS_H_
#define MVBRDF_CORE_BASE_STATUS_MACROS_H_

#include "absl/status/status.h"
#include "absl/status/statusor.h"

#define MVBRDF_STATUS_CONCAT_INNER_(a, b) a##b
#define MVBRDF_STATUS_CONCAT_(a, b) MVBRDF_STATUS_CONCAT_INNER_(a, b)

// Returns from the enclosing function if `expr` (an absl::Status) is not OK.
#define MVBRDF_RETURN_IF_ERROR(expr)                  \
  do {                                                \
    ::absl::Status mvbrdf_status_ = (expr);           \
    if (!mvbrdf_status_.ok()) return mvbrdf_status_;  \
  } while (false)

// `lhs = value of rexpr` or return its error. `lhs` may declare a variable:
//   MVBRDF_ASSIGN_OR_RETURN(auto mesh, LoadMesh(path));
#define MVBRDF_ASSIGN_OR_RETURN(lhs, rexpr) \
  MVBRDF_ASSIGN_OR_RETURN_IMPL_(MVBRDF_STATUS_CONCAT_(mvbrdf_statusor_, __LINE__), lhs, rexpr)

#define MVBRDF_ASSIGN_OR_RETURN_IMPL_(statusor, lhs, rexpr) \
  auto statusor = (rexpr);                                  \
  if (!statusor.ok()) return std::move(statusor).status();  \
  lhs = std::move(statusor).value()

#endif  // MVBRDF_CORE_BASE_STATUS_MACROS_H_
