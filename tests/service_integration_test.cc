// The service end to end, in one process: a real server on a loopback port,
// real workers (each with its own EGL context) on threads, real SQLite and
// real video files, driven over the client-facing gRPC API exactly as
// `mvbrdf submit/watch/fetch/cancel` drive it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <set>
#include <thread>

#include "client/bundle_upload.h"
#include "client/embedded_service.h"
#include "core/base/files.h"
#include "core/bundle/bundle.h"
#include "core/bundle/sha256.h"
#include "core/pipeline/job_options.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf {
namespace {

namespace fs = std::filesystem;

class ServiceIntegrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mvbrdf_service_integration_test_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    {
      auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
      ASSERT_TRUE(context.ok()) << context.status();
      synth::SynthOptions so;
      so.num_cameras = 4;
      so.num_frames = 3;
      so.out_dir = dir_ / "bundle";
      auto synthesized = synth::Synthesize(so, **context);
      ASSERT_TRUE(synthesized.ok()) << synthesized.status();
    }
    auto info = bundle::PackBundle(dir_ / "bundle" / "scene.json", dir_ / "bundle.tar");
    ASSERT_TRUE(info.ok()) << info.status();
    bundle_ = new bundle::BundleInfo(*info);
    client::EmbeddedOptions eo;
    eo.data_dir = dir_ / "server";
    eo.workers = 2;
    eo.egl = gl::EglPlatform::kSurfaceless;
    eo.threads_per_worker = 1;
    auto service = client::EmbeddedService::Start(eo);
    ASSERT_TRUE(service.ok()) << service.status();
    service_ = service->release();
    stub_ = v1::Mvbrdf::NewStub(service_->channel()).release();
    client::UploadOutcome outcome;
    ASSERT_TRUE(client::UploadBundleFile(*stub_, "tests", dir_ / "bundle.tar", bundle_->sha256,
                                         static_cast<uint64_t>(bundle_->size), nullptr, &outcome)
                    .ok());
  }
  static void TearDownTestSuite() {
    delete stub_;
    delete service_;
    delete bundle_;
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  static v1::SubmitJobRequest Request() {
    v1::SubmitJobRequest request;
    request.set_bundle_sha256(bundle_->sha256);
    request.mutable_options()->set_atlas_size(128);
    request.mutable_options()->set_compare_solvers(false);
    return request;
  }

  static v1::Job Submit(const v1::SubmitJobRequest& request) {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", "tests");
    v1::SubmitJobResponse response;
    const grpc::Status status = stub_->SubmitJob(&context, request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response.job();
  }

  // Every event of the job until it ends.
  static std::vector<v1::JobEvent> Watch(const std::string& job_id) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::minutes(5));
    v1::WatchJobRequest request;
    request.set_job_id(job_id);
    auto reader = stub_->WatchJob(&context, request);
    std::vector<v1::JobEvent> events;
    v1::JobEvent event;
    while (reader->Read(&event)) {
      events.push_back(event);
      if (event.has_state() && (event.state() == v1::SUCCEEDED || event.state() == v1::FAILED ||
                                event.state() == v1::CANCELLED)) {
        context.TryCancel();
        break;
      }
    }
    reader->Finish();
    return events;
  }

  static v1::JobState FinalState(const std::vector<v1::JobEvent>& events) {
    for (auto it = events.rbegin(); it != events.rend(); ++it) {
      if (it->has_state()) return it->state();
    }
    return v1::JOB_STATE_UNSPECIFIED;
  }

  static v1::Job GetJob(const std::string& job_id) {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", "tests");
    v1::ListJobsRequest request;
    v1::ListJobsResponse response;
    EXPECT_TRUE(stub_->ListJobs(&context, request, &response).ok());
    for (const v1::Job& job : response.jobs()) {
      if (job.id() == job_id) return job;
    }
    ADD_FAILURE() << "job " << job_id << " not listed";
    return v1::Job();
  }

  static std::string Fetch(const std::string& job_id, const std::string& name) {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", "tests");
    v1::FetchArtifactRequest request;
    request.set_job_id(job_id);
    request.set_name(name);
    auto reader = stub_->FetchArtifact(&context, request);
    std::string bytes, sha256;
    v1::ArtifactChunk chunk;
    while (reader->Read(&chunk)) {
      if (chunk.offset() == 0) sha256 = chunk.sha256();
      EXPECT_EQ(chunk.offset(), bytes.size());
      bytes += chunk.data();
    }
    const grpc::Status status = reader->Finish();
    EXPECT_TRUE(status.ok()) << name << ": " << status.error_message();
    EXPECT_EQ(bundle::Sha256Bytes(bytes), sha256) << name;
    return bytes;
  }

  static std::string ReadFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  static fs::path dir_;
  static bundle::BundleInfo* bundle_;
  static client::EmbeddedService* service_;
  static v1::Mvbrdf::Stub* stub_;
};

fs::path ServiceIntegrationTest::dir_;
bundle::BundleInfo* ServiceIntegrationTest::bundle_ = nullptr;
client::EmbeddedService* ServiceIntegrationTest::service_ = nullptr;
v1::Mvbrdf::Stub* ServiceIntegrationTest::stub_ = nullptr;

TEST_F(ServiceIntegrationTest, SubmitWatchFetchEqualsADirectLibraryRun) {
  const v1::Job job = Submit(Request());
  const std::vector<v1::JobEvent> events = Watch(job.id());
  ASSERT_EQ(FinalState(events), v1::SUCCEEDED);
  // The events tell the story: stages started by named workers, progress, stages finished with metrics, artifacts.
  int started = 0, finished = 0, artifacts = 0, progress = 0;
  for (const v1::JobEvent& e : events) {
    if (e.has_stage_started()) {
      ++started;
      EXPECT_FALSE(e.stage_started().worker().empty());
    }
    if (e.has_stage_finished()) {
      ++finished;
      EXPECT_FALSE(e.stage_finished().worker_name().empty());
      EXPECT_FALSE(e.stage_finished().task_id().empty());
    }
    if (e.has_artifact()) ++artifacts;
    if (e.has_progress()) ++progress;
  }
  // gather (replayed when it was leased before the watch began), 8 sweeps, choose, reflectance.
  EXPECT_EQ(started, 1 + 8 + 1 + 1);
  EXPECT_EQ(finished, 1 + 8 + 1 + 1);  // one event per finished task (issue #20)
  EXPECT_GT(progress, 0);
  EXPECT_GT(artifacts, 5);

  // The same job run directly by the library.
  auto sequence = scene::LoadSequence(dir_ / "bundle" / "scene.json");
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  auto options = pipeline::ReconstructOptionsFor(Request(), 1);
  ASSERT_TRUE(options.ok());
  options->out_dir = dir_ / "direct";
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok());
  auto direct = pipeline::RunReconstruction(*sequence, **context, *options);
  ASSERT_TRUE(direct.ok()) << direct.status();
  for (const char* name : {"atlases/kd.exr", "atlases/ks.exr", "atlases/ke.exr", "atlases/cluster.exr",
                           "atlases/confidence.exr", "atlases/correction/0000.exr", "atlas/mesh.obj"}) {
    EXPECT_EQ(Fetch(job.id(), name), ReadFile(dir_ / "direct" / name)) << name;
  }
  const v1::Job done = GetJob(job.id());
  ASSERT_EQ(done.report().light_configurations_size(), 8);
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(done.report().light_configurations(i).e_d(), direct->light_configurations(i).e_d());
  }
  EXPECT_EQ(done.report().chosen_configuration(), direct->chosen_configuration());
  // Every task says who ran it and how long it took.
  for (const v1::TaskInfo& task : done.tasks()) {
    EXPECT_EQ(task.state(), "done") << task.kind();
    EXPECT_FALSE(task.worker().empty()) << task.kind();
    EXPECT_GT(task.seconds(), 0.0) << task.kind();  // from its lease to its result
  }
}

TEST_F(ServiceIntegrationTest, SweepOverEightConfigurationsUsesBothWorkers) {
  v1::SubmitJobRequest request = Request();
  request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
  const v1::Job job = Submit(request);
  ASSERT_EQ(FinalState(Watch(job.id())), v1::SUCCEEDED);
  std::set<std::string> workers;
  int sweeps = 0;
  const v1::Job done = GetJob(job.id());
  for (const v1::TaskInfo& task : done.tasks()) {
    if (task.kind() != "sweep") continue;
    ++sweeps;
    workers.insert(task.worker());
  }
  EXPECT_EQ(sweeps, 8);
  EXPECT_EQ(workers.size(), 2u) << "both workers should have taken sweep tasks";
  // A light-table job ends with choose's result.json.
  EXPECT_NE(Fetch(job.id(), "result.json").find("chosenConfiguration"), std::string::npos);
}

TEST_F(ServiceIntegrationTest, RepeatedSweepIsServedFromTheSampleCache) {
  v1::SubmitJobRequest request = Request();
  request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
  request.mutable_options()->set_sweep_frame_stride(2);  // a cache key of its own
  const v1::Job first = Submit(request);
  ASSERT_EQ(FinalState(Watch(first.id())), v1::SUCCEEDED);
  const v1::Job second = Submit(request);
  ASSERT_EQ(FinalState(Watch(second.id())), v1::SUCCEEDED);
  const v1::Job a = GetJob(first.id()), b = GetJob(second.id());
  for (const v1::TaskInfo& task : a.tasks()) EXPECT_FALSE(task.samples_from_cache()) << task.kind();
  int from_cache = 0;
  for (const v1::TaskInfo& task : b.tasks()) {
    if (task.kind() == "gather" || task.kind() == "sweep") {
      EXPECT_TRUE(task.samples_from_cache()) << task.kind() << " " << task.key();
      ++from_cache;
    }
  }
  EXPECT_EQ(from_cache, 9);
  // The same table from the cached Samples.
  ASSERT_EQ(a.report().light_configurations_size(), b.report().light_configurations_size());
  for (int i = 0; i < a.report().light_configurations_size(); ++i) {
    EXPECT_EQ(a.report().light_configurations(i).e_d(), b.report().light_configurations(i).e_d());
  }
}

TEST_F(ServiceIntegrationTest, CancelledJobStopsAndTheServiceGoesOn) {
  const v1::Job job = Submit(Request());
  // Cancel it while it runs: once its first task is done.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  bool running = false;
  while (!running && std::chrono::steady_clock::now() < give_up) {
    const v1::Job now = GetJob(job.id());
    for (const v1::TaskInfo& task : now.tasks()) running = running || task.state() == "done";
    if (!running) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(running);
  {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", "tests");
    v1::CancelJobRequest request;
    request.set_job_id(job.id());
    v1::Job cancelled;
    const grpc::Status status = stub_->CancelJob(&context, request, &cancelled);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_EQ(FinalState(Watch(job.id())), v1::CANCELLED);
  const v1::Job ended = GetJob(job.id());
  EXPECT_EQ(ended.state(), v1::CANCELLED);
  for (const v1::TaskInfo& task : ended.tasks()) {
    EXPECT_NE(task.state(), "queued") << task.kind();
    if (task.kind() == "reflectance") {
      EXPECT_EQ(task.state(), "cancelled");
    }
  }
  // Workers are free again: the next job runs.
  v1::SubmitJobRequest request = Request();
  request.set_configuration("NE,NW,SE,SW");
  request.add_outputs(v1::OUTPUT_BRDF_ATLASES);
  const v1::Job next = Submit(request);
  EXPECT_EQ(FinalState(Watch(next.id())), v1::SUCCEEDED);
}

TEST_F(ServiceIntegrationTest, JobSubmittedTwiceRunsTwiceWithTheSameResults) {
  v1::SubmitJobRequest request = Request();
  request.set_configuration("NE,NW,SE,SW");
  request.add_outputs(v1::OUTPUT_BRDF_ATLASES);
  const v1::Job a = Submit(request);
  const v1::Job b = Submit(request);
  EXPECT_NE(a.id(), b.id());
  EXPECT_EQ(FinalState(Watch(a.id())), v1::SUCCEEDED);
  EXPECT_EQ(FinalState(Watch(b.id())), v1::SUCCEEDED);
  EXPECT_EQ(Fetch(a.id(), "atlases/kd.exr"), Fetch(b.id(), "atlases/kd.exr"));
  // The bundle is stored once: a second upload sends nothing.
  client::UploadOutcome outcome;
  ASSERT_TRUE(client::UploadBundleFile(*stub_, "tests", dir_ / "bundle.tar", bundle_->sha256,
                                       static_cast<uint64_t>(bundle_->size), nullptr, &outcome)
                  .ok());
  EXPECT_TRUE(outcome.already_there);
  // Each worker downloaded the bundle at most once across all jobs.
  for (const auto& w : service_->workers()) EXPECT_LE(w->bundle_downloads(), 1);
}

// Embedded workers read the bundle the server unpacked when it validated
// the job: none downloads or unpacks it again (issue #17).
TEST_F(ServiceIntegrationTest, EmbeddedWorkersReadTheServersUnpackedBundle) {
  v1::SubmitJobRequest request = Request();
  request.set_configuration("NE,NW,SE,SW");
  EXPECT_EQ(FinalState(Watch(Submit(request).id())), v1::SUCCEEDED);
  ASSERT_TRUE(fs::is_directory(dir_ / "server" / "scenes" / bundle_->sha256));
  for (size_t i = 0; i < service_->workers().size(); ++i) {
    EXPECT_EQ(service_->workers()[i]->bundle_downloads(), 0) << i;
    EXPECT_FALSE(fs::exists(dir_ / "server" / ("worker-" + std::to_string(i)) / "bundles" / bundle_->sha256)) << i;
  }
}

// AdoptBundle makes a packed file the server's bundle without an upload: the
// file moves, an upload of the same bytes finds it there, a job runs on it.
TEST_F(ServiceIntegrationTest, AnAdoptedBundleIsAsIfUploaded) {
  const fs::path other = dir_ / "adopted";
  fs::copy(dir_ / "bundle", other, fs::copy_options::recursive);
  {
    std::ofstream scene(other / "scene.json", std::ios::app);
    scene << "\n";  // other bytes, another digest
  }
  const fs::path archive = dir_ / "server" / "adopt.tar";  // the server's file system
  auto info = bundle::PackBundle(other / "scene.json", archive);
  ASSERT_TRUE(info.ok()) << info.status();
  ASSERT_NE(info->sha256, bundle_->sha256);
  ASSERT_TRUE(service_->AdoptBundle(archive, info->sha256).ok());
  EXPECT_FALSE(fs::exists(archive));
  auto again = bundle::PackBundle(other / "scene.json", dir_ / "adopted.tar");
  ASSERT_TRUE(again.ok()) << again.status();
  client::UploadOutcome outcome;
  ASSERT_TRUE(client::UploadBundleFile(*stub_, "tests", dir_ / "adopted.tar", again->sha256,
                                       static_cast<uint64_t>(again->size), nullptr, &outcome)
                  .ok());
  EXPECT_TRUE(outcome.already_there);
  v1::SubmitJobRequest request = Request();
  request.set_bundle_sha256(info->sha256);
  request.set_configuration("NE,NW,SE,SW");
  EXPECT_EQ(FinalState(Watch(Submit(request).id())), v1::SUCCEEDED);
  // A digest that is not one is refused, the file left where it was.
  ASSERT_TRUE(fs::copy_file(dir_ / "adopted.tar", archive));
  EXPECT_EQ(service_->AdoptBundle(archive, "not-a-digest").code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(fs::exists(archive));
}

// Bytes of `mib` MiB in a file under dir_ (the server checks the hash, not
// the contents, until a job names the bundle), with their SHA-256.
struct UploadBytes {
  fs::path file;
  std::string sha256;
  std::string bytes;
};

UploadBytes MakeUploadBytes(const fs::path& file, int mib, uint32_t multiplier) {
  {
    std::ofstream out(file, std::ios::binary);
    for (int i = 0; i < mib * 1024 * 1024; ++i) out.put(static_cast<char>((i * multiplier) >> 24));
  }
  auto sha256 = bundle::Sha256File(file);
  EXPECT_TRUE(sha256.ok()) << sha256.status();
  auto bytes = ReadFileToString(file);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return {file, sha256.value_or(""), bytes.value_or("")};
}

// The first MiB of `upload` as the first chunk of an UploadBundle stream.
v1::UploadChunk FirstMiB(const UploadBytes& upload) {
  v1::UploadChunk chunk;
  chunk.set_sha256(upload.sha256);
  chunk.set_total_size(upload.bytes.size());
  chunk.set_offset(0);
  chunk.set_data(upload.bytes.substr(0, 1 << 20));
  return chunk;
}

TEST_F(ServiceIntegrationTest, AnInterruptedUploadResumesWhereItStopped) {
  const UploadBytes upload = MakeUploadBytes(dir_ / "resumable.bin", 3, 2654435761u);
  const fs::path& file = upload.file;
  const std::string* sha256 = &upload.sha256;
  const std::string& bytes = upload.bytes;
  {
    // The first MiB, then the client goes away.
    grpc::ClientContext context;
    v1::UploadStatus status;
    auto writer = stub_->UploadBundle(&context, &status);
    ASSERT_TRUE(writer->Write(FirstMiB(upload)));
    writer->WritesDone();
    writer->Finish();
    EXPECT_FALSE(status.complete());
    EXPECT_EQ(status.received_bytes(), 1u << 20);
  }
  client::UploadOutcome outcome;
  const absl::Status uploaded =
      client::UploadBundleFile(*stub_, "tests", file, *sha256, bytes.size(), nullptr, &outcome);
  ASSERT_TRUE(uploaded.ok()) << uploaded;
  EXPECT_FALSE(outcome.already_there);
  EXPECT_EQ(outcome.resumed_at, 1u << 20);
  client::UploadOutcome again;
  ASSERT_TRUE(client::UploadBundleFile(*stub_, "tests", file, *sha256, bytes.size(), nullptr, &again).ok());
  EXPECT_TRUE(again.already_there);
}

TEST_F(ServiceIntegrationTest, ASecondUploadOfTheSameBundleWaitsForTheFirst) {
  // Two clients send the same bytes at once: the server takes one stream at
  // a time, the other client waits and finds the bundle complete (or takes
  // over from the prefix) instead of failing its submit.
  const UploadBytes upload = MakeUploadBytes(dir_ / "concurrent.bin", 2, 40503u << 16);
  const fs::path& file = upload.file;
  const std::string* sha256 = &upload.sha256;
  const std::string& bytes = upload.bytes;
  grpc::ClientContext context;
  v1::UploadStatus first_status;
  auto writer = stub_->UploadBundle(&context, &first_status);
  ASSERT_TRUE(writer->Write(FirstMiB(upload)));
  // Write() returning says only that the chunk is queued: wait until the
  // server holds it (a loaded machine let the second upload claim first).
  for (int i = 0; i < 500; ++i) {
    grpc::ClientContext query_context;
    v1::QueryUploadRequest query;
    query.set_sha256(*sha256);
    v1::UploadStatus progress;
    if (stub_->QueryUpload(&query_context, query, &progress).ok() && progress.received_bytes() >= (1u << 20)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // The first stream holds the bundle; the second upload starts now.
  absl::Status second = absl::UnknownError("not run");
  client::UploadOutcome outcome;
  std::thread other([&] {
    second = client::UploadBundleFile(*stub_, "tests", file, *sha256, bytes.size(), nullptr, &outcome);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  v1::UploadChunk rest;
  rest.set_offset(1 << 20);
  rest.set_data(bytes.substr(1 << 20));
  ASSERT_TRUE(writer->Write(rest));
  writer->WritesDone();
  const grpc::Status finished = writer->Finish();
  other.join();
  EXPECT_TRUE(finished.ok()) << finished.error_message();
  EXPECT_TRUE(first_status.complete());
  ASSERT_TRUE(second.ok()) << second;
  EXPECT_TRUE(outcome.already_there) << "the second client sent bytes the first had already sent";
}

}  // namespace
}  // namespace mvbrdf
