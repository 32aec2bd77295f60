// MvbrdfService over a real loopback channel: an in-process server on
// 127.0.0.1:0, real SQLite stores and data dir in a temporary directory, a
// fake clock, and a small real scene bundle made by the project's own
// synthesizer and packer.
#include "server/clients_api/mvbrdf_service.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <thread>

#include "absl/strings/str_join.h"
#include "core/base/files.h"
#include "core/bundle/bundle.h"
#include "core/gl/egl_context.h"
#include "core/scene/sequence.h"
#include "core/synth/synthesizer.h"
#include "server/store/digest.h"
#include "server/store/test_dir.h"

namespace mvbrdf::clients_api {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kConfigurations = 8;  // the synthetic actor's candidates
constexpr int64_t kStartMs = 1'700'000'000'000;

struct Bundle {
  std::string bytes;
  std::string sha256;
};

Bundle PackToBytes(const fs::path& scene_file, const fs::path& archive) {
  auto info = bundle::PackBundle(scene_file, archive);
  EXPECT_TRUE(info.ok()) << info.status();
  auto bytes = ReadFileToString(archive);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return {*bytes, info.ok() ? info->sha256 : ""};
}

class MvbrdfServiceTest : public ::testing::Test {
 protected:
  // One synthetic scene for the suite (2 cameras, 2 frames, 64x48), packed
  // as is and with camera 0's fx edited to -1.
  static void SetUpTestSuite() {
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    scene_dir_ = new fs::path(fs::temp_directory_path() / ("mvbrdf_clients_api_test_" + std::to_string(::getpid())));
    fs::remove_all(*scene_dir_);
    synth::SynthOptions o;
    o.num_cameras = 2;
    o.num_frames = 2;
    o.width = 64;
    o.height = 48;
    o.actor_segments = 8;
    o.shadow_map_size = 256;
    o.noise_sigma = 0.0;
    o.out_dir = *scene_dir_ / "good";
    auto result = synth::Synthesize(o, **context);
    ASSERT_TRUE(result.ok()) << result.status();
    good_ = new Bundle(PackToBytes(result->scene_file, *scene_dir_ / "good.tar"));

    // PackBundle validates the scene, so the bad bundle is the good one
    // with camera 0's fx overwritten in place (same length: the tar headers
    // stay valid).
    bad_ = new Bundle{good_->bytes, ""};
    // (the scene.json entry: ground_truth/truth.json before it names fx too)
    const size_t header = bad_->bytes.find(std::string("scene.json\0", 11));
    ASSERT_NE(header, std::string::npos);
    const size_t key = bad_->bytes.find("\"fx\":", header);
    ASSERT_NE(key, std::string::npos);
    size_t begin = key + 5;
    while (bad_->bytes[begin] == ' ') ++begin;
    const size_t end = bad_->bytes.find_first_of(",\n}", begin);
    ASSERT_GE(end - begin, 2u);
    bad_->bytes.replace(begin, end - begin, "-1" + std::string(end - begin - 2, ' '));
    bad_->sha256 = store::Sha256Hex(bad_->bytes);
  }
  static void TearDownTestSuite() {
    if (scene_dir_ != nullptr) fs::remove_all(*scene_dir_);
    delete scene_dir_;
    delete good_;
    delete bad_;
  }

  void SetUp() override {
    ASSERT_NE(good_, nullptr);
    auto jobs = store::JobStore::Open(dir_.db());
    ASSERT_TRUE(jobs.ok()) << jobs.status();
    jobs_ = *std::move(jobs);
    auto artifacts = store::ArtifactStore::Open(dir_.db(), dir_.path() / "artifacts");
    ASSERT_TRUE(artifacts.ok()) << artifacts.status();
    artifacts_ = *std::move(artifacts);
    ServiceLimits limits;
    limits.max_bundle_bytes = 64 << 20;
    limits.max_jobs_per_client = 3;
    limits.watch_poll_ms = 20;
    ASSERT_TRUE(limits.Check().ok());
    service_ = std::make_unique<MvbrdfService>(
        *jobs_, *artifacts_, dir_.path(), [this] { return now_ms_.load(); }, limits, [this] { ++notified_; });
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.SetMaxReceiveMessageSize(static_cast<int>(limits.max_message_bytes));
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = v1::Mvbrdf::NewStub(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  }

  void TearDown() override {
    if (server_ != nullptr) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(5));
    server_.reset();
    service_.reset();
  }

  static std::unique_ptr<grpc::ClientContext> Context(const std::string& client = "alice") {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
    context->AddMetadata("x-mvbrdf-client", client);
    return context;
  }

  struct Chunk {
    uint64_t offset;
    std::string data;
  };
  // One UploadBundle call sending `chunks` (the first names the bundle).
  grpc::Status Upload(const std::string& sha256, uint64_t total, const std::vector<Chunk>& chunks,
                      v1::UploadStatus* status) {
    auto context = Context();
    auto writer = stub_->UploadBundle(context.get(), status);
    for (size_t i = 0; i < chunks.size(); ++i) {
      v1::UploadChunk chunk;
      if (i == 0) {
        chunk.set_sha256(sha256);
        chunk.set_total_size(total);
      }
      chunk.set_offset(chunks[i].offset);
      chunk.set_data(chunks[i].data);
      if (!writer->Write(chunk)) break;  // the server finished early
    }
    writer->WritesDone();
    return writer->Finish();
  }

  // The good bundle in three chunks.
  void UploadGood() {
    const std::string& b = good_->bytes;
    const size_t third = b.size() / 3;
    v1::UploadStatus status;
    const grpc::Status s = Upload(good_->sha256, b.size(),
                                  {{0, b.substr(0, third)},
                                   {third, b.substr(third, third)},
                                   {2 * third, b.substr(2 * third)}},
                                  &status);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_TRUE(status.complete());
    EXPECT_EQ(status.received_bytes(), b.size());
  }

  v1::UploadStatus Query(const std::string& sha256) {
    auto context = Context();
    v1::QueryUploadRequest request;
    request.set_sha256(sha256);
    v1::UploadStatus status;
    const grpc::Status s = stub_->QueryUpload(context.get(), request, &status);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return status;
  }

  grpc::Status Submit(const v1::SubmitJobRequest& request, v1::Job* job, const std::string& client = "alice") {
    auto context = Context(client);
    v1::SubmitJobResponse response;
    const grpc::Status s = stub_->SubmitJob(context.get(), request, &response);
    *job = response.job();
    return s;
  }

  v1::Job SubmitGood(const std::string& client = "alice") {
    v1::SubmitJobRequest request;
    request.set_bundle_sha256(good_->sha256);
    v1::Job job;
    const grpc::Status s = Submit(request, &job, client);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return job;
  }

  static fs::path* scene_dir_;
  static Bundle* good_;
  static Bundle* bad_;

  store::TestDir dir_;
  std::atomic<int64_t> now_ms_{kStartMs};
  std::atomic<int> notified_{0};
  std::unique_ptr<store::JobStore> jobs_;
  std::unique_ptr<store::ArtifactStore> artifacts_;
  std::unique_ptr<MvbrdfService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::Mvbrdf::Stub> stub_;
};

fs::path* MvbrdfServiceTest::scene_dir_ = nullptr;
Bundle* MvbrdfServiceTest::good_ = nullptr;
Bundle* MvbrdfServiceTest::bad_ = nullptr;

TEST_F(MvbrdfServiceTest, UploadInChunksIsStoredOnceAndCompleteAtOnceAgain) {
  EXPECT_EQ(Query(good_->sha256).received_bytes(), 0u);
  UploadGood();
  const v1::UploadStatus query = Query(good_->sha256);
  EXPECT_TRUE(query.complete());
  EXPECT_EQ(query.received_bytes(), good_->bytes.size());
  EXPECT_TRUE(fs::is_regular_file(dir_.path() / "bundles" / (good_->sha256 + ".tar")));

  // The same bundle again: complete after the first chunk, stored once.
  v1::UploadStatus again;
  const grpc::Status s = Upload(good_->sha256, good_->bytes.size(), {{0, good_->bytes.substr(0, 100)}}, &again);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_TRUE(again.complete());
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_.path() / "bundles")) files += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1);
  EXPECT_TRUE(fs::is_empty(dir_.path() / "uploads"));
}

TEST_F(MvbrdfServiceTest, UploadResumesWhereItStopped) {
  const std::string& b = good_->bytes;
  const size_t first = b.size() / 3;
  v1::UploadStatus status;
  grpc::Status s = Upload(good_->sha256, b.size(), {{0, b.substr(0, first)}}, &status);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_FALSE(status.complete());
  EXPECT_EQ(status.received_bytes(), first);
  EXPECT_EQ(Query(good_->sha256).received_bytes(), first);

  // Starting over at 0 is refused, naming the expected offset.
  s = Upload(good_->sha256, b.size(), {{0, b.substr(0, first)}}, &status);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(s.error_message(), HasSubstr("offset: expected " + std::to_string(first)));

  s = Upload(good_->sha256, b.size(), {{first, b.substr(first)}}, &status);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_TRUE(status.complete());
  EXPECT_TRUE(Query(good_->sha256).complete());
}

TEST_F(MvbrdfServiceTest, UploadRejectsHashMismatchAndBadHeaders) {
  const std::string claimed = store::Sha256Hex("something else");
  v1::UploadStatus status;
  grpc::Status s = Upload(claimed, good_->bytes.size(), {{0, good_->bytes}}, &status);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("upload hash does not match"));
  EXPECT_EQ(Query(claimed).received_bytes(), 0u);
  EXPECT_FALSE(fs::exists(dir_.path() / "uploads" / (claimed + ".part")));

  s = Upload("ABC", 10, {{0, "0123456789"}}, &status);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("sha256"));

  s = Upload(good_->sha256, uint64_t{1} << 40, {{0, "x"}}, &status);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("total_size"));
}

TEST_F(MvbrdfServiceTest, SubmitCreatesTheTaskGraph) {
  UploadGood();
  const v1::Job job = SubmitGood();
  EXPECT_EQ(job.state(), v1::QUEUED);
  EXPECT_EQ(job.client(), "alice");
  EXPECT_EQ(job.bundle_sha256(), good_->sha256);
  EXPECT_EQ(job.created_unix_ms(), kStartMs);
  EXPECT_EQ(job.tasks_size(), 1 + kConfigurations + 2);
  EXPECT_EQ(notified_.load(), 1);

  auto tasks = jobs_->TasksOfJob(job.id());
  ASSERT_TRUE(tasks.ok()) << tasks.status();
  ASSERT_EQ(tasks->size(), static_cast<size_t>(1 + kConfigurations + 2));
  const store::Task& gather = tasks->front();
  EXPECT_EQ(gather.kind, "gather");
  EXPECT_TRUE(gather.depends_on.empty());
  // The sweeps are created (and so leased) most lights first; choose reads
  // them in the scene's order.
  auto scene = scene::ReadScene(*scene_dir_ / "good" / "scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->light_configurations_size(), kConfigurations);
  std::map<std::string, int> lights_of;
  for (const auto& c : scene->light_configurations()) lights_of[c.name()] = c.lights_size();
  std::map<std::string, std::string> sweep_of;
  int previous_lights = 1 << 30;
  for (int i = 1; i <= kConfigurations; ++i) {
    const store::Task& sweep = (*tasks)[i];
    EXPECT_EQ(sweep.kind, "sweep");
    ASSERT_EQ(lights_of.count(sweep.key), 1u) << sweep.key;
    EXPECT_LE(lights_of[sweep.key], previous_lights) << sweep.key;
    previous_lights = lights_of[sweep.key];
    EXPECT_EQ(sweep.depends_on, std::vector<std::string>{gather.id});
    sweep_of[sweep.key] = sweep.id;
  }
  EXPECT_GT(lights_of[(*tasks)[1].key], lights_of[(*tasks)[kConfigurations].key]);
  const store::Task& choose = (*tasks)[kConfigurations + 1];
  EXPECT_EQ(choose.kind, "choose");
  std::vector<std::string> choose_deps = {gather.id};
  for (const auto& c : scene->light_configurations()) choose_deps.push_back(sweep_of[c.name()]);
  EXPECT_EQ(choose.depends_on, choose_deps);
  const store::Task& reflectance = tasks->back();
  EXPECT_EQ(reflectance.kind, "reflectance");
  EXPECT_EQ(reflectance.depends_on, std::vector<std::string>{choose.id});
  auto stored = jobs_->GetJob(job.id());
  ASSERT_TRUE(stored.ok());
  EXPECT_TRUE(stored->sealed);
  v1::SubmitJobRequest request;
  ASSERT_TRUE(request.ParseFromString(stored->request));
  EXPECT_EQ(request.bundle_sha256(), good_->sha256);
}

TEST_F(MvbrdfServiceTest, SubmitWithKnownConfigurationHasNoSweep) {
  UploadGood();
  v1::SubmitJobRequest request;
  request.set_bundle_sha256(good_->sha256);
  request.set_configuration("NE,NW,SE,SW");
  v1::Job job;
  grpc::Status s = Submit(request, &job);
  ASSERT_TRUE(s.ok()) << s.error_message();
  auto tasks = jobs_->TasksOfJob(job.id());
  ASSERT_TRUE(tasks.ok());
  ASSERT_EQ(tasks->size(), 2u);
  EXPECT_EQ((*tasks)[0].kind, "gather");
  EXPECT_EQ((*tasks)[1].kind, "reflectance");
  EXPECT_EQ((*tasks)[1].key, "NE,NW,SE,SW");
  EXPECT_EQ((*tasks)[1].depends_on, std::vector<std::string>{(*tasks)[0].id});

  // The light table alone: gather and the sweep, no reflectance.
  request.clear_configuration();
  request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
  s = Submit(request, &job);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(job.tasks_size(), 1 + kConfigurations + 1);
  EXPECT_EQ(job.tasks(job.tasks_size() - 1).kind(), "choose");

  request.set_configuration("nope");
  s = Submit(request, &job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("configuration"));
}

TEST_F(MvbrdfServiceTest, SubmitRefusesUnknownBundlesAndInvalidScenes) {
  v1::SubmitJobRequest request;
  request.set_bundle_sha256(good_->sha256);
  v1::Job job;
  grpc::Status s = Submit(request, &job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(s.error_message(), HasSubstr("bundle_sha256"));

  v1::UploadStatus status;
  s = Upload(bad_->sha256, bad_->bytes.size(), {{0, bad_->bytes}}, &status);
  ASSERT_TRUE(s.ok()) << s.error_message();
  request.set_bundle_sha256(bad_->sha256);
  s = Submit(request, &job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("fx"));

  // The server keeps serving, and nothing was queued.
  auto context = Context();
  v1::ListJobsResponse jobs;
  s = stub_->ListJobs(context.get(), v1::ListJobsRequest(), &jobs);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(jobs.jobs_size(), 0);
  EXPECT_EQ(notified_.load(), 0);
}

TEST_F(MvbrdfServiceTest, ListCancelAndPerClientLimit) {
  UploadGood();
  std::vector<v1::Job> submitted;
  for (int i = 0; i < 3; ++i) {
    now_ms_ += 1000;
    submitted.push_back(SubmitGood());
  }
  v1::SubmitJobRequest request;
  request.set_bundle_sha256(good_->sha256);
  v1::Job job;
  grpc::Status s = Submit(request, &job);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("alice"));
  EXPECT_TRUE(Submit(request, &job, "bob").ok());

  auto context = Context();
  v1::CancelJobRequest cancel;
  cancel.set_job_id(submitted[1].id());
  v1::Job cancelled;
  s = stub_->CancelJob(context.get(), cancel, &cancelled);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(cancelled.state(), v1::CANCELLED);
  for (const v1::TaskInfo& t : cancelled.tasks()) EXPECT_EQ(t.state(), "cancelled");

  context = Context();
  cancel.set_job_id(std::string(32, 'f'));
  s = stub_->CancelJob(context.get(), cancel, &cancelled);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);

  // A cancelled job frees a place.
  s = Submit(request, &job);
  ASSERT_TRUE(s.ok()) << s.error_message();

  context = Context();
  v1::ListJobsResponse list;
  s = stub_->ListJobs(context.get(), v1::ListJobsRequest(), &list);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(list.jobs_size(), 4);
  EXPECT_EQ(list.jobs(0).id(), submitted[0].id());
  EXPECT_EQ(list.jobs(1).state(), v1::CANCELLED);
  EXPECT_EQ(list.jobs(0).tasks_size(), 1 + kConfigurations + 2);
  context = Context();
  v1::ListJobsRequest two;
  two.set_limit(2);
  s = stub_->ListJobs(context.get(), two, &list);
  ASSERT_TRUE(s.ok());
  ASSERT_EQ(list.jobs_size(), 2);
  EXPECT_EQ(list.jobs(1).id(), job.id());
  context = Context("bob");
  s = stub_->ListJobs(context.get(), v1::ListJobsRequest(), &list);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(list.jobs_size(), 1);
}

// A client that cancels its watch right after reading an event: the server's
// stream ends every time. (It did not when the cancel arrived while the
// event's write was still completing: OnCancel left the finish to
// OnWriteDone, which then saw a successful write and waited for more, so the
// stream lived on and the server's shutdown hung; seen once in 15 minutes of
// the sanitizer suite.) Each round also checks a pushed event still reaches a
// live watch.
TEST_F(MvbrdfServiceTest, AbandonedWatchesAreAllReleased) {
  UploadGood();
  const v1::Job job = SubmitGood();
  for (int round = 0; round < 100; ++round) {
    auto context = Context();
    v1::WatchJobRequest request;
    request.set_job_id(job.id());
    auto reader = stub_->WatchJob(context.get(), request);
    v1::JobEvent event;
    ASSERT_TRUE(reader->Read(&event)) << round;
    EXPECT_EQ(event.state(), v1::QUEUED);
    if (round % 2 == 1) {  // an event being written as the client cancels
      v1::JobEvent progress;
      progress.set_job_id(job.id());
      progress.mutable_progress()->set_fraction(0.25);
      service_->PushEvent(progress);
    }
    context->TryCancel();
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED) << round;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (service_->ActiveWatches() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(service_->ActiveWatches(), 0u) << "watch streams the server never ended";
}

TEST_F(MvbrdfServiceTest, WatchSeesQueuedPushedEventsThenCancelledAndEnds) {
  UploadGood();
  const v1::Job job = SubmitGood();
  const v1::Job other = SubmitGood();

  // A watch the client abandons leaves its job alone.
  {
    auto context = Context();
    v1::WatchJobRequest request;
    request.set_job_id(other.id());
    auto reader = stub_->WatchJob(context.get(), request);
    v1::JobEvent event;
    ASSERT_TRUE(reader->Read(&event));
    EXPECT_EQ(event.state(), v1::QUEUED);
    context->TryCancel();
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }

  auto context = Context();
  v1::WatchJobRequest request;
  request.set_job_id(job.id());
  auto reader = stub_->WatchJob(context.get(), request);
  v1::JobEvent event;
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_EQ(event.job_id(), job.id());
  EXPECT_EQ(event.state(), v1::QUEUED);

  v1::JobEvent progress;
  progress.set_job_id(job.id());
  progress.mutable_progress()->set_stage("gather");
  progress.mutable_progress()->set_fraction(0.5);
  service_->PushEvent(progress);
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_DOUBLE_EQ(event.progress().fraction(), 0.5);

  now_ms_ += 5000;
  ASSERT_TRUE(jobs_->CancelJob(job.id(), now_ms_).ok());
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_EQ(event.state(), v1::CANCELLED);
  EXPECT_EQ(event.unix_ms(), now_ms_.load());
  EXPECT_FALSE(reader->Read(&event));
  const grpc::Status s = reader->Finish();
  EXPECT_TRUE(s.ok()) << s.error_message();

  auto still = jobs_->GetJob(other.id());
  ASSERT_TRUE(still.ok());
  EXPECT_EQ(still->state, store::JobState::kQueued);

  // A finished job replays its final state and ends; unknown ids are NOT_FOUND.
  context = Context();
  reader = stub_->WatchJob(context.get(), request);
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_EQ(event.state(), v1::CANCELLED);
  EXPECT_FALSE(reader->Read(&event));
  EXPECT_TRUE(reader->Finish().ok());
  context = Context();
  request.set_job_id(std::string(32, 'f'));
  reader = stub_->WatchJob(context.get(), request);
  EXPECT_FALSE(reader->Read(&event));
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(MvbrdfServiceTest, WatchReportsFinishedStagesAndSuccess) {
  UploadGood();
  v1::SubmitJobRequest submit;
  submit.set_bundle_sha256(good_->sha256);
  submit.set_configuration("NE,NW,SE,SW");
  v1::Job job;
  ASSERT_TRUE(Submit(submit, &job).ok());

  auto context = Context();
  v1::WatchJobRequest request;
  request.set_job_id(job.id());
  auto reader = stub_->WatchJob(context.get(), request);
  v1::JobEvent event;
  ASSERT_TRUE(reader->Read(&event));
  EXPECT_EQ(event.state(), v1::QUEUED);
  // Stand in for a worker: lease and complete both tasks.
  for (int i = 0; i < 2; ++i) {
    auto task = jobs_->LeaseTask("w1", now_ms_, 60'000);
    ASSERT_TRUE(task.ok() && task->has_value());
    ASSERT_TRUE(jobs_->CompleteTask((*task)->id, "w1", "ok", now_ms_).ok());
  }
  std::vector<std::string> seen;
  while (reader->Read(&event)) {
    if (event.has_stage_finished()) {
      const v1::StageFinished& f = event.stage_finished();
      seen.push_back(f.key().empty() ? f.stage() : f.stage() + "[" + f.key() + "]");
      EXPECT_FALSE(f.task_id().empty());
    }
    // (RUNNING only when a poll fell between the two completions.)
    if (event.event_case() == v1::JobEvent::kState && event.state() != v1::RUNNING) {
      seen.push_back(v1::JobState_Name(event.state()));
    }
  }
  EXPECT_TRUE(reader->Finish().ok());
  // Each finished task once (issue #20), then the final state.
  EXPECT_EQ(seen, (std::vector<std::string>{"gather", "reflectance[NE,NW,SE,SW]", "SUCCEEDED"}))
      << absl::StrJoin(seen, " ");
}

// Issue #20: a finished stage is one event, with the worker's numbers kept
// with the task (a pushed copy is not sent again), its key, task and worker
// name; a late watch replays the same. ListArtifacts lists a succeeded
// job's artifacts by name; NOT_FOUND for an unknown job, FAILED_PRECONDITION
// before success; cancelling a succeeded job answers its state.
TEST_F(MvbrdfServiceTest, FinishedStagesAreOneEventWithTheWorkersNumbers) {
  UploadGood();
  v1::SubmitJobRequest submit;
  submit.set_bundle_sha256(good_->sha256);
  submit.set_configuration("NE,NW,SE,SW");
  v1::Job job;
  ASSERT_TRUE(Submit(submit, &job).ok());
  auto list = [&](const std::string& id, v1::ListArtifactsResponse* response) {
    auto context = Context();
    v1::ListArtifactsRequest request;
    request.set_job_id(id);
    return stub_->ListArtifacts(context.get(), request, response);
  };
  v1::ListArtifactsResponse listed;
  EXPECT_EQ(list(job.id(), &listed).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(list(std::string(32, 'f'), &listed).error_code(), grpc::StatusCode::NOT_FOUND);

  ASSERT_TRUE(jobs_->RegisterWorker("w1", "studio-gpu-1", now_ms_).ok());
  for (int i = 0; i < 2; ++i) {
    auto task = jobs_->LeaseTask("w1", now_ms_, 60'000);
    ASSERT_TRUE(task.ok() && task->has_value());
    v1::StageFinished finished;
    finished.set_stage((*task)->kind);
    finished.set_seconds(1.25 + i);
    (*finished.mutable_metrics())["E_d"] = 0.5;
    ASSERT_TRUE(jobs_->SetStageFinished((*task)->id, "w1", finished.SerializeAsString()).ok());
    v1::JobEvent pushed;  // as the workers' service forwards it: not sent again
    pushed.set_job_id(job.id());
    *pushed.mutable_stage_finished() = finished;
    service_->PushEvent(pushed);
    ASSERT_TRUE(jobs_->CompleteTask((*task)->id, "w1", "ok", now_ms_).ok());
  }
  ASSERT_TRUE(artifacts_->PutBytes(job.id(), "result.json", "{}", now_ms_).ok());
  ASSERT_TRUE(artifacts_->PutBytes(job.id(), "atlases/kd.exr", "kd", now_ms_).ok());
  for (int watch = 0; watch < 2; ++watch) {
    auto context = Context();
    v1::WatchJobRequest request;
    request.set_job_id(job.id());
    auto reader = stub_->WatchJob(context.get(), request);
    v1::JobEvent event;
    std::vector<v1::StageFinished> finished;
    while (reader->Read(&event)) {
      if (event.has_stage_finished()) finished.push_back(event.stage_finished());
    }
    EXPECT_TRUE(reader->Finish().ok());
    ASSERT_EQ(finished.size(), 2u);
    EXPECT_EQ(finished[0].stage(), "gather");
    EXPECT_DOUBLE_EQ(finished[0].seconds(), 1.25);
    EXPECT_EQ(finished[1].stage(), "reflectance");
    EXPECT_EQ(finished[1].key(), "NE,NW,SE,SW");
    EXPECT_DOUBLE_EQ(finished[1].seconds(), 2.25);
    EXPECT_DOUBLE_EQ(finished[1].metrics().at("E_d"), 0.5);
    EXPECT_EQ(finished[1].worker_name(), "studio-gpu-1");
    EXPECT_EQ(finished[1].task_id().size(), 32u);
  }
  ASSERT_TRUE(list(job.id(), &listed).ok());
  ASSERT_EQ(listed.artifacts_size(), 2);
  EXPECT_EQ(listed.artifacts(0).name(), "atlases/kd.exr");
  EXPECT_EQ(listed.artifacts(0).size(), 2u);
  EXPECT_EQ(listed.artifacts(1).name(), "result.json");
  EXPECT_EQ(listed.artifacts(1).sha256().size(), 64u);

  auto context = Context();
  v1::CancelJobRequest cancel;
  cancel.set_job_id(job.id());
  v1::Job answered;
  const grpc::Status s = stub_->CancelJob(context.get(), cancel, &answered);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(answered.state(), v1::SUCCEEDED);
  for (const v1::TaskInfo& t : answered.tasks()) EXPECT_EQ(t.worker_name(), "studio-gpu-1");
}

TEST_F(MvbrdfServiceTest, FetchArtifactRoundTripsInChunks) {
  std::string bytes(int64_t{5} << 19, '\0');  // 2.5 MiB: three chunks
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>((i * 7919) >> 3);
  auto put = artifacts_->PutBytes("job1", "atlases/kd.exr", bytes, now_ms_);
  ASSERT_TRUE(put.ok()) << put.status();

  auto context = Context();
  v1::FetchArtifactRequest request;
  request.set_job_id("job1");
  request.set_name("atlases/kd.exr");
  auto reader = stub_->FetchArtifact(context.get(), request);
  v1::ArtifactChunk chunk;
  std::string fetched;
  int chunks = 0;
  uint64_t total = 0;
  std::string sha256;
  while (reader->Read(&chunk)) {
    if (chunks++ == 0) {
      total = chunk.total_size();
      sha256 = chunk.sha256();
    }
    EXPECT_EQ(chunk.offset(), fetched.size());
    fetched += chunk.data();
  }
  const grpc::Status s = reader->Finish();
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(chunks, 3);
  EXPECT_EQ(total, bytes.size());
  EXPECT_EQ(sha256, put->sha256);
  EXPECT_EQ(store::Sha256Hex(fetched), sha256);
  EXPECT_EQ(fetched, bytes);

  context = Context();
  request.set_name("atlases/ks.exr");
  reader = stub_->FetchArtifact(context.get(), request);
  EXPECT_FALSE(reader->Read(&chunk));
  const grpc::Status missing = reader->Finish();
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(missing.error_message(), HasSubstr("atlases/ks.exr"));
}

}  // namespace
}  // namespace mvbrdf::clients_api
