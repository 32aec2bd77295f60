// mvbrdf: measure spatially varying BRDFs from multi-view video of a tracked
// mesh. One binary, one subcommand per task.
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "client/commands.h"
#include "client/connection.h"
#include "core/scene/names.h"

namespace {

constexpr char kUsage[] =
    "usage: mvbrdf COMMAND [ARGS...]\n"
    "\n"
    "commands:\n"
    "  synth      render a synthetic multi-view sequence with its ground truth\n"
    "  import     write a scene from a camera calibration (COLMAP, OpenCV, Metashape): cameras, mesh, videos, lights\n"
    "  validate   load a scene, check everything, print a summary or the errors\n"
    "  resample   resample every frame into the texture atlas; coverage, timing and error vs truth\n"
    "  run        reconstruct the BRDF: light sweep, clustering, fitting, atlases, errors\n"
    "  render     draw a reconstruction from any camera under any lights\n"
    "  export     write a reconstruction as glTF 2.0 (.glb, .gltf): mesh, PBR material, cameras, lights\n"
    "  evaluate   compare a reconstruction with the synthetic generator's ground truth\n"
    "  report     the HTML report of a reconstruction (plots, tables, atlases, renderings)\n"
    "  server     run the job server (gRPC; state in --data)\n"
    "  worker     run an EGL-headless worker for a server\n"
    "  jobs       list jobs on a server\n"
    "  submit     upload a scene's bundle to a server and queue a job\n"
    "  watch      follow a job's events until it ends\n"
    "  artifacts  list a job's outputs (name, size, sha256) for fetch\n"
    "  fetch      download a job's artifacts\n"
    "  cancel     cancel a job\n"
    "  health     ask a server's gRPC health service (for probes); exit 0 when serving\n"
    "  version    mvbrdf's version, git commit and library versions (also --version)\n"
    "\n"
    "'mvbrdf COMMAND --help' describes a command's options.\n"
    "terms (E_a, E_d, Tables 6.1, 6.2, 7.1, Samples, clusters, ...): docs/glossary.md\n"
    "Service commands: a job that does not exist, an artifact it does not have and 'artifacts' of a job\n"
    "  without results are invalid input; 'cancel' of a job that already finished exits ok, saying so.\n"
    "exit codes: 0 ok, 1 internal error, 2 usage, 3 invalid input, 4 environment (EGL, codecs, files,\n"
    "  disk full, memory, server unreachable or at its limits), 5 the watched job failed, 6 the watched\n"
    "  job was cancelled, 7 the server refused the credentials (no, unknown or wrong-role token)\n";

}  // namespace

namespace {

int Dispatch(int argc, char** argv);

}  // namespace

// The commands turn what they can foresee into a Status; an allocation that
// fails anywhere else still ends with a message and exit 4, not an abort.
int main(int argc, char** argv) {
  try {
    return Dispatch(argc, argv);
  } catch (const std::bad_alloc& e) {
    std::fprintf(stderr, "mvbrdf: error: out of memory (%s)\n", e.what());
    return mvbrdf::client::kExitEnvironment;
  } catch (const cv::Exception& e) {
    std::fprintf(stderr, "mvbrdf: error: %s\n", e.what());
    return e.code == cv::Error::StsNoMem ? mvbrdf::client::kExitEnvironment : mvbrdf::client::kExitInternal;
  }
}

namespace {

int Dispatch(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h" ||
      std::string(argv[1]) == "help") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? mvbrdf::client::kExitUsage : mvbrdf::client::kExitOk;
  }
  const std::string command = argv[1];
  if (command == "--version") return mvbrdf::client::RunVersion({argv + 2, argv + argc});
  const std::vector<std::string> args(argv + 2, argv + argc);
  // One-shot clients print one line per failure; gRPC's own log would repeat it.
  for (const char* client : {"jobs", "submit", "watch", "fetch", "artifacts", "cancel", "health"}) {
    if (command == client) mvbrdf::client::QuietGrpcLog();
  }
  if (command == "synth") return mvbrdf::client::RunSynth(args);
  if (command == "import") return mvbrdf::client::RunImport(args);
  if (command == "validate") return mvbrdf::client::RunValidate(args);
  if (command == "resample") return mvbrdf::client::RunResample(args);
  if (command == "run") return mvbrdf::client::RunRun(args);
  if (command == "render") return mvbrdf::client::RunRender(args);
  if (command == "export") return mvbrdf::client::RunExport(args);
  if (command == "evaluate") return mvbrdf::client::RunEvaluate(args);
  if (command == "report") return mvbrdf::client::RunReport(args);
  if (command == "server") return mvbrdf::client::RunServer(args);
  if (command == "worker") return mvbrdf::client::RunWorker(args);
  if (command == "jobs") return mvbrdf::client::RunJobs(args);
  if (command == "submit") return mvbrdf::client::RunSubmit(args);
  if (command == "watch") return mvbrdf::client::RunWatch(args);
  if (command == "fetch") return mvbrdf::client::RunFetch(args);
  if (command == "cancel") return mvbrdf::client::RunCancel(args);
  if (command == "artifacts") return mvbrdf::client::RunArtifacts(args);
  if (command == "health") return mvbrdf::client::RunHealth(args);
  if (command == "version") return mvbrdf::client::RunVersion(args);
  // The closest command, when it is a likely typo ("rnu": did you mean "run"?).
  const std::vector<std::string> commands = {"synth",  "import", "validate", "resample",  "run",   "render", "export",
                                             "evaluate", "report", "server", "worker",   "jobs",   "submit",
                                             "watch",  "artifacts", "fetch", "cancel",   "health", "version"};
  const std::string closest = mvbrdf::scene::ClosestName(command, commands);
  std::fprintf(stderr, "mvbrdf: unknown command \"%s\"%s\n\n%s", mvbrdf::scene::ShownName(command).c_str(),
               closest.empty() ? "" : ("; did you mean \"" + closest + "\"?").c_str(), kUsage);
  return mvbrdf::client::kExitUsage;
}

}  // namespace
