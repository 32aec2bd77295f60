// The `mvbrdf` subcommands. Each takes the arguments after its name and
// returns the process exit code (see ExitCode).
#ifndef MVBRDF_CLIENT_COMMANDS_H_
#define MVBRDF_CLIENT_COMMANDS_H_

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace mvbrdf::client {

// Exit codes scripts can rely on.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,      // a bug or an unexpected failure
  kExitUsage = 2,         // bad command line
  kExitInvalidInput = 3,  // the scene or its files are not valid
  kExitEnvironment = 4,   // EGL/GL, codecs or the file system are not usable
};

// Maps a Status to an exit code and prints its one-line reason on stderr.
int ReportFailure(const absl::Status& status);

int RunSynth(const std::vector<std::string>& args);
int RunValidate(const std::vector<std::string>& args);
int RunResample(const std::vector<std::string>& args);
int RunRun(const std::vector<std::string>& args);
int RunEvaluate(const std::vector<std::string>& args);
int RunRender(const std::vector<std::string>& args);
int RunServer(const std::vector<std::string>& args);
int RunJobs(const std::vector<std::string>& args);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_COMMANDS_H_
