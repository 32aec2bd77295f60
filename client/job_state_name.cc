#include "client/job_state_name.h"

namespace mvbrdf::client {

const char* JobStateName(v1::JobState state) {
  switch (state) {
    case v1::QUEUED: return "queued";
    case v1::RUNNING: return "running";
    case v1::SUCCEEDED: return "succeeded";
    case v1::FAILED: return "failed";
    case v1::CANCELLED: return "cancelled";
    default: return "?";
  }
}

}  // namespace mvbrdf::client
