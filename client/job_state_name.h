// A job state as the client prints it ("queued", "running", ...).
#ifndef MVBRDF_CLIENT_JOB_STATE_NAME_H_
#define MVBRDF_CLIENT_JOB_STATE_NAME_H_

#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::client {

const char* JobStateName(v1::JobState state);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_JOB_STATE_NAME_H_
