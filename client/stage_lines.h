// How `watch` and `run` show a job's stage events: one line per started and
// per finished task, naming its stage, its key (e.g. the configuration of a
// sweep), its worker by --name and, when finished, its run time and metrics
// (issue #20: each finished stage was shown twice, half of it each time).
#ifndef MVBRDF_CLIENT_STAGE_LINES_H_
#define MVBRDF_CLIENT_STAGE_LINES_H_

#include <string>
#include <vector>

#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::client {

// "stage sweep "NE" started on w1 (worker ID, task ID)".
std::string StageStartedLine(const v1::StageStarted& started);
// "stage sweep "NE" finished in 0.42 s on w1  E_a=0.0123 E_d=0.0456", then a
// warning line per flagged cluster fit (metrics "flag/CLUSTER/FLAG").
std::vector<std::string> StageFinishedLines(const v1::StageFinished& finished);
// How a worker is shown: its name, else its id (a server before issue #20).
std::string WorkerShown(const std::string& name, const std::string& id);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_STAGE_LINES_H_
