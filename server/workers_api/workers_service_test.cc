// WorkersService over a real gRPC channel (loopback, port chosen by the OS),
// an in-process server, real SQLite stores in a temporary directory and a
// fake clock for leases.
#include "server/workers_api/workers_service.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "core/samples/sample_set.h"
#include "server/store/digest.h"
#include "server/store/sqlite_db.h"
#include "server/store/test_dir.h"
#include "server/workers_api/sample_key.h"

namespace mvbrdf::server {
namespace {

using std::chrono::milliseconds;
using std::chrono::steady_clock;

constexpr int64_t kT0 = 1'700'000'000'000;  // unix ms
constexpr int64_t kLeaseMs = 30'000;        // the default lease_seconds
// How late a woken long poll may answer, and the slack around a timed wait.
constexpr auto kWakeLatency = milliseconds(100);
constexpr auto kWaitSlack = milliseconds(400);

class WorkersServiceTest : public ::testing::Test {
 protected:
  void Start(WorkersServiceOptions options = {}) {
    auto jobs = store::JobStore::Open(dir_.db());
    ASSERT_TRUE(jobs.ok()) << jobs.status();
    jobs_ = std::move(*jobs);
    auto artifacts = store::ArtifactStore::Open(dir_.db(), dir_.path() / "artifacts");
    ASSERT_TRUE(artifacts.ok()) << artifacts.status();
    artifacts_ = std::move(*artifacts);
    auto samples = store::SampleCache::Open(dir_.db(), cache_options_);
    ASSERT_TRUE(samples.ok()) << samples.status();
    samples_ = std::move(*samples);
    service_ = std::make_unique<WorkersService>(
        *jobs_, *artifacts_, *samples_, [this](absl::string_view sha256) { return BundlePath(sha256); },
        [this] { return now_ms_.load(); }, options, [this](const v1::JobEvent& event) {
          std::lock_guard<std::mutex> lock(events_mu_);
          events_.push_back(event);
        });
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    ASSERT_GT(port, 0);
    stub_ = v1::Workers::NewStub(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  }

  void TearDown() override {
    if (service_) service_->Stop();
    if (server_) server_->Shutdown();
    server_.reset();
    service_.reset();
  }

  static void SetDeadline(grpc::ClientContext& context) {
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  }

  std::string Register(const std::string& name) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::RegisterWorkerRequest request;
    request.set_name(name);
    request.set_gl_renderer("llvmpipe");
    request.set_threads(2);
    v1::RegisterWorkerResponse response;
    const grpc::Status status = stub_->RegisterWorker(&context, request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response.worker_id();
  }

  grpc::Status Lease(const std::string& worker, uint32_t wait_seconds, v1::LeaseTaskResponse* response) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::LeaseTaskRequest request;
    request.set_worker_id(worker);
    request.set_wait_seconds(wait_seconds);
    return stub_->LeaseTask(&context, request, response);
  }

  grpc::Status Renew(const std::string& worker, const std::string& task, v1::RenewLeaseResponse* response) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::RenewLeaseRequest request;
    request.set_worker_id(worker);
    request.set_task_id(task);
    return stub_->RenewLease(&context, request, response);
  }

  // Sends `updates` on one ReportTask stream.
  grpc::Status Report(const std::vector<v1::TaskUpdate>& updates, v1::TaskUpdateAck* ack) {
    grpc::ClientContext context;
    SetDeadline(context);
    auto writer = stub_->ReportTask(&context, ack);
    for (const v1::TaskUpdate& update : updates) {
      if (!writer->Write(update)) break;  // the server finished early
    }
    writer->WritesDone();
    return writer->Finish();
  }

  static v1::SubmitJobRequest SampleRequest() {
    v1::SubmitJobRequest request;
    request.set_bundle_sha256(std::string(64, 'a'));
    request.set_scene_path("scene.json");
    request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
    request.add_configurations("key+fill");
    request.add_configurations("key");
    request.mutable_options()->set_atlas_size(256);
    return request;
  }

  // A sealed job with one "sweep" task; returns {job, task}.
  std::pair<std::string, std::string> AddJob(const std::string& request_bytes) {
    auto job = jobs_->CreateJob(store::NewJob{"alice", std::string(64, 'a'), request_bytes}, now_ms_);
    EXPECT_TRUE(job.ok()) << job.status();
    auto task = jobs_->AddTask(store::NewTask{*job, "sweep", "key+fill", std::nullopt, 0}, now_ms_);
    EXPECT_TRUE(task.ok()) << task.status();
    EXPECT_TRUE(jobs_->SealJob(*job, now_ms_).ok());
    return {*job, *task};
  }

  static v1::TaskUpdate Update(const std::string& worker, const std::string& task) {
    v1::TaskUpdate update;
    update.set_worker_id(worker);
    update.set_task_id(task);
    return update;
  }

  std::vector<v1::JobEvent> Events() {
    std::lock_guard<std::mutex> lock(events_mu_);
    return events_;
  }

  std::filesystem::path BundlePath(absl::string_view sha256) const {
    return dir_.path() / "bundles" / (std::string(sha256) + ".tar");
  }

  // A sealed job of the real graph's shape: gather, then one sweep on it.
  // Returns {job, gather, sweep}.
  std::tuple<std::string, std::string, std::string> AddGatherJob(const std::string& bundle = std::string(64, 'a')) {
    v1::SubmitJobRequest request = SampleRequest();
    request.set_bundle_sha256(bundle);
    auto job = jobs_->CreateJob(store::NewJob{"alice", bundle, request.SerializeAsString()}, now_ms_);
    EXPECT_TRUE(job.ok()) << job.status();
    auto gather = jobs_->AddTask(store::NewTask{*job, "gather", "", std::nullopt, 0}, now_ms_);
    EXPECT_TRUE(gather.ok()) << gather.status();
    auto sweep = jobs_->AddTask(store::NewTask{*job, "sweep", "key+fill", *gather, 0}, now_ms_);
    EXPECT_TRUE(sweep.ok()) << sweep.status();
    EXPECT_TRUE(jobs_->SealJob(*job, now_ms_).ok());
    return {*job, *gather, *sweep};
  }

  // An encoded triangle SampleSet with `count` samples and two lights.
  static std::string EncodedSamples(int count) {
    samples::SampleSet set;
    set.light_names = {"key", "fill"};
    set.light_intensity = {glm::vec3(1.0f), glm::vec3(0.5f)};
    for (int i = 0; i < count; ++i) {
      const float g[2] = {0.25f, 0.5f};
      const float h[2] = {0.125f, 0.0f};
      set.Add(static_cast<uint32_t>(i), i % 3, 0, glm::vec3(0.1f * static_cast<float>(i % 7)), g, h);
    }
    return samples::EncodeSampleSet(set);
  }

  // The updates of a gather task: the Samples in chunks of `chunk` bytes,
  // then a GatherResult naming `claimed_sha256`.
  static std::vector<v1::TaskUpdate> GatherUpdates(const std::string& worker, const std::string& task,
                                                   const std::string& encoded, size_t chunk,
                                                   const std::string& claimed_sha256) {
    std::vector<v1::TaskUpdate> updates;
    for (size_t offset = 0; offset < encoded.size(); offset += chunk) {
      v1::TaskUpdate update = Update(worker, task);
      update.mutable_samples()->set_offset(offset);
      update.mutable_samples()->set_data(encoded.substr(offset, chunk));
      if (offset == 0) {
        update.mutable_samples()->set_total_size(encoded.size());
        update.mutable_samples()->set_sha256(store::Sha256Hex(encoded));
      }
      updates.push_back(update);
    }
    v1::GatherResult gathered;
    gathered.set_samples_sha256(claimed_sha256);
    gathered.set_samples(3);
    gathered.set_encoded_bytes(encoded.size());
    gathered.mutable_calibration()->set_cameras_mode("on");
    gathered.mutable_calibration()->set_cameras_decision("refined for the test");
    v1::TaskUpdate result = Update(worker, task);
    result.set_result(gathered.SerializeAsString());
    updates.push_back(result);
    return updates;
  }

  struct Fetched {
    grpc::Status status;
    std::string bytes;
    std::string sha256;  // of the first chunk
    uint64_t total_size = 0;
    int chunks = 0;
  };

  static Fetched ReadAll(grpc::ClientReaderInterface<v1::ArtifactChunk>& reader) {
    Fetched fetched;
    v1::ArtifactChunk chunk;
    while (reader.Read(&chunk)) {
      if (fetched.chunks == 0) {
        fetched.sha256 = chunk.sha256();
        fetched.total_size = chunk.total_size();
      }
      EXPECT_EQ(chunk.offset(), fetched.bytes.size());
      fetched.bytes += chunk.data();
      ++fetched.chunks;
    }
    fetched.status = reader.Finish();
    return fetched;
  }

  Fetched FetchBundle(const std::string& worker, const std::string& sha256) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::FetchBundleRequest request;
    request.set_worker_id(worker);
    request.set_sha256(sha256);
    auto reader = stub_->FetchBundle(&context, request);
    return ReadAll(*reader);
  }

  Fetched FetchSamples(const std::string& worker, const std::string& task) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::FetchSamplesRequest request;
    request.set_worker_id(worker);
    request.set_task_id(task);
    auto reader = stub_->FetchSamples(&context, request);
    return ReadAll(*reader);
  }

  store::TestDir dir_;
  store::SampleCacheOptions cache_options_;  // set before Start()
  std::atomic<int64_t> now_ms_{kT0};
  std::unique_ptr<store::JobStore> jobs_;
  std::unique_ptr<store::ArtifactStore> artifacts_;
  std::unique_ptr<store::SampleCache> samples_;
  std::unique_ptr<WorkersService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::Workers::Stub> stub_;
  std::mutex events_mu_;
  std::vector<v1::JobEvent> events_;
};

TEST_F(WorkersServiceTest, RegistersWorkersAndRejectsBadNames) {
  Start();
  const std::string id = Register("gpu-box-1");
  EXPECT_EQ(id.size(), 32u);
  EXPECT_NE(Register("gpu-box-2"), id);
  const std::optional<RegisteredWorker> worker = service_->FindWorker(id);
  ASSERT_TRUE(worker.has_value());
  EXPECT_EQ(worker->name, "gpu-box-1");
  EXPECT_EQ(worker->gl_renderer, "llvmpipe");
  EXPECT_EQ(worker->threads, 2u);
  EXPECT_EQ(service_->ListWorkers().size(), 2u);

  for (const std::string& bad : {std::string(), std::string(129, 'x')}) {
    grpc::ClientContext context;
    SetDeadline(context);
    v1::RegisterWorkerRequest request;
    request.set_name(bad);
    v1::RegisterWorkerResponse response;
    const grpc::Status status = stub_->RegisterWorker(&context, request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("name"), std::string::npos) << status.error_message();
  }

  v1::LeaseTaskResponse response;
  EXPECT_EQ(Lease("no-such-worker", 0, &response).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(WorkersServiceTest, LongPollWithNothingQueuedReturnsEmptyAfterWaitSeconds) {
  Start();
  const std::string worker = Register("w");
  const auto start = steady_clock::now();
  v1::LeaseTaskResponse response;
  const grpc::Status status = Lease(worker, 1, &response);
  const auto elapsed = steady_clock::now() - start;
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(response.has_task());
  EXPECT_GE(elapsed, std::chrono::seconds(1) - milliseconds(50));
  EXPECT_LE(elapsed, std::chrono::seconds(1) + kWaitSlack);
}

TEST_F(WorkersServiceTest, LeasesAQueuedTaskWithItsRequestParsed) {
  Start();
  const std::string worker = Register("w");
  const v1::SubmitJobRequest request = SampleRequest();
  const auto [job, task] = AddJob(request.SerializeAsString());

  v1::LeaseTaskResponse response;
  const grpc::Status status = Lease(worker, 0, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(response.has_task());
  const v1::Task& leased = response.task();
  EXPECT_EQ(leased.id(), task);
  EXPECT_EQ(leased.job_id(), job);
  EXPECT_EQ(leased.kind(), "sweep");
  EXPECT_EQ(leased.key(), "key+fill");
  EXPECT_EQ(leased.bundle_sha256(), std::string(64, 'a'));
  EXPECT_EQ(leased.request().SerializeAsString(), request.SerializeAsString());
  EXPECT_EQ(leased.request().configurations_size(), 2);
  EXPECT_EQ(leased.lease_expires_unix_ms(), kT0 + kLeaseMs);

  const std::vector<v1::JobEvent> events = service_->RecordedEvents(job);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].stage_started().task_id(), task);
  EXPECT_EQ(events[0].stage_started().worker(), worker);
}

TEST_F(WorkersServiceTest, TaskWhoseRequestDoesNotParseFailsWithAReason) {
  Start();
  const std::string worker = Register("w");
  const auto [job, task] = AddJob(std::string("\xff\xff\xff not a proto"));
  v1::LeaseTaskResponse response;
  ASSERT_TRUE(Lease(worker, 0, &response).ok());
  EXPECT_FALSE(response.has_task());
  auto stored = jobs_->GetJob(job);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, store::JobState::kFailed);  // after max_attempts
  EXPECT_NE(stored->error.find("SubmitJobRequest"), std::string::npos) << stored->error;
}

TEST_F(WorkersServiceTest, NotifyWorkWakesALongPoll) {
  WorkersServiceOptions options;
  options.poll_interval_ms = 5000;  // only NotifyWork can answer in time
  Start(options);
  const std::string worker = Register("w");
  std::promise<steady_clock::time_point> answered;
  v1::LeaseTaskResponse response;
  grpc::Status status;
  std::thread poll([&] {
    status = Lease(worker, 10, &response);
    answered.set_value(steady_clock::now());
  });
  std::this_thread::sleep_for(milliseconds(300));  // parked by now
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  const auto notified = steady_clock::now();
  service_->NotifyWork();
  const auto answer = answered.get_future().get();
  poll.join();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(response.has_task());
  EXPECT_EQ(response.task().id(), task);
  EXPECT_LT(answer - notified, kWakeLatency);
}

TEST_F(WorkersServiceTest, OwnerRenewsTheLeaseAndOthersAreRefused) {
  Start();
  const std::string owner = Register("owner");
  const std::string other = Register("other");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(owner, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());

  now_ms_ += 10'000;
  v1::RenewLeaseResponse renewed;
  const grpc::Status status = Renew(owner, task, &renewed);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(renewed.lease_expires_unix_ms(), kT0 + 10'000 + kLeaseMs);
  auto stored = jobs_->GetTask(task);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->lease_expires_ms, kT0 + 10'000 + kLeaseMs);

  EXPECT_EQ(Renew(other, task, &renewed).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(Renew("unknown", task, &renewed).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(WorkersServiceTest, ExpiredLeaseGoesToAnotherWorkerAndTheOldOwnerIsRefused) {
  Start();
  const std::string first = Register("first");
  const std::string second = Register("second");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(first, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());

  // The second worker is parked when the lease expires: the poller's timer
  // (not a NotifyWork) hands it the task.
  std::promise<steady_clock::time_point> answered;
  v1::LeaseTaskResponse taken;
  grpc::Status status;
  std::thread poll([&] {
    status = Lease(second, 5, &taken);
    answered.set_value(steady_clock::now());
  });
  std::this_thread::sleep_for(milliseconds(100));
  now_ms_ += kLeaseMs + 1;
  const auto expired = steady_clock::now();
  const auto answer = answered.get_future().get();
  poll.join();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(taken.has_task());
  EXPECT_EQ(taken.task().id(), task);
  EXPECT_LT(answer - expired, milliseconds(250) + kWaitSlack);

  v1::TaskUpdate progress = Update(first, task);
  progress.mutable_progress()->set_stage("sweep");
  progress.mutable_progress()->set_fraction(0.5);
  v1::TaskUpdateAck ack;
  ack.set_accepted(true);
  ASSERT_TRUE(Report({progress}, &ack).ok());
  EXPECT_FALSE(ack.accepted());

  v1::RenewLeaseResponse renewed;
  EXPECT_EQ(Renew(first, task, &renewed).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(WorkersServiceTest, ReportWithProgressArtifactAndResultCompletesTheTask) {
  Start();
  const std::string worker = Register("w");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());

  std::string artifact(3000, '\0');
  for (size_t i = 0; i < artifact.size(); ++i) artifact[i] = static_cast<char>(i * 7 % 251);
  const std::string sha256 = store::Sha256Hex(artifact);

  std::vector<v1::TaskUpdate> updates;
  v1::TaskUpdate progress = Update(worker, task);
  progress.mutable_progress()->set_stage("sweep");
  progress.mutable_progress()->set_fraction(0.25);
  updates.push_back(progress);
  progress.mutable_progress()->set_fraction(0.75);
  updates.push_back(progress);
  for (int i = 0; i < 3; ++i) {
    v1::TaskUpdate chunk = Update(worker, task);
    chunk.set_artifact_name("tables/light.csv");
    chunk.mutable_artifact()->set_offset(1000 * i);
    chunk.mutable_artifact()->set_data(artifact.substr(1000 * i, 1000));
    if (i == 0) {
      chunk.mutable_artifact()->set_total_size(artifact.size());
      chunk.mutable_artifact()->set_sha256(sha256);
    }
    updates.push_back(chunk);
  }
  v1::TaskUpdate finished = Update(worker, task);
  finished.mutable_stage_finished()->set_stage("sweep");
  finished.mutable_stage_finished()->set_seconds(1.5);
  (*finished.mutable_stage_finished()->mutable_metrics())["E_a"] = 0.01;
  updates.push_back(finished);
  v1::TaskUpdate result = Update(worker, task);
  result.set_result("row-bytes");
  updates.push_back(result);

  v1::TaskUpdateAck ack;
  const grpc::Status status = Report(updates, &ack);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(ack.accepted());

  auto stored = jobs_->GetTask(task);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, store::TaskState::kDone);
  EXPECT_EQ(stored->result.value_or(""), "row-bytes");
  auto stored_job = jobs_->GetJob(job);
  ASSERT_TRUE(stored_job.ok());
  EXPECT_EQ(stored_job->state, store::JobState::kSucceeded);

  auto artifacts = artifacts_->ArtifactsOfJob(job);
  ASSERT_TRUE(artifacts.ok()) << artifacts.status();
  ASSERT_EQ(artifacts->size(), 1u);
  EXPECT_EQ((*artifacts)[0].name, "tables/light.csv");
  EXPECT_EQ((*artifacts)[0].sha256, sha256);
  auto bytes = artifacts_->Read(sha256);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(*bytes, artifact);

  // Recorded for watchers: stage started, the latest progress, the
  // artifact, the stage finished, the final state.
  const std::vector<v1::JobEvent> recorded = service_->RecordedEvents(job);
  ASSERT_EQ(recorded.size(), 5u);
  EXPECT_TRUE(recorded[0].has_stage_started());
  EXPECT_DOUBLE_EQ(recorded[1].progress().fraction(), 0.75);
  EXPECT_EQ(recorded[2].artifact().sha256(), sha256);
  EXPECT_EQ(recorded[2].artifact().size(), artifact.size());
  EXPECT_DOUBLE_EQ(recorded[3].stage_finished().metrics().at("E_a"), 0.01);
  EXPECT_EQ(recorded[4].state(), v1::SUCCEEDED);
  EXPECT_EQ(Events().size(), 6u);  // the sink also saw the first progress
}

TEST_F(WorkersServiceTest, RejectsBadArtifactChunks) {
  WorkersServiceOptions options;
  options.max_artifact_bytes = 1000;
  Start(options);
  const std::string worker = Register("w");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());

  v1::TaskUpdate chunk = Update(worker, task);
  chunk.set_artifact_name("big.exr");
  chunk.mutable_artifact()->set_total_size(1001);
  chunk.mutable_artifact()->set_data("x");
  v1::TaskUpdateAck ack;
  EXPECT_EQ(Report({chunk}, &ack).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);

  chunk.mutable_artifact()->set_total_size(10);
  v1::TaskUpdate gap = chunk;
  gap.mutable_artifact()->set_offset(5);
  gap.mutable_artifact()->set_total_size(0);
  const grpc::Status status = Report({chunk, gap}, &ack);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("offset"), std::string::npos) << status.error_message();

  v1::TaskUpdate wrong_hash = chunk;
  wrong_hash.mutable_artifact()->set_total_size(1);
  wrong_hash.mutable_artifact()->set_sha256(std::string(64, '0'));
  EXPECT_EQ(Report({wrong_hash}, &ack).error_code(), grpc::StatusCode::DATA_LOSS);

  // Names that would place a client's copy outside its output directory.
  for (const std::string& bad : std::vector<std::string>{"../escape.exr", "/etc/cron.d/x", "atlases/../../x", "atlases/./kd.exr",
                                                          std::string(300, 'n')}) {
    v1::TaskUpdate named = chunk;
    named.set_artifact_name(bad);
    const grpc::Status refused = Report({named}, &ack);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad;
    EXPECT_NE(refused.error_message().find("artifact_name"), std::string::npos) << refused.error_message();
  }
}

TEST_F(WorkersServiceTest, ReportedFailureRequeuesTheTask) {
  Start();
  const std::string first = Register("first");
  const std::string second = Register("second");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(first, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());

  v1::TaskUpdate failed = Update(first, task);
  failed.set_failed("EGL: no display");
  v1::TaskUpdateAck ack;
  const grpc::Status status = Report({failed}, &ack);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(ack.accepted());
  auto stored = jobs_->GetTask(task);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, store::TaskState::kQueued);
  // The reason names the worker (issue #19: which of them failed it).
  EXPECT_EQ(stored->error, "EGL: no display (on worker " + first + " \"first\")");
  EXPECT_EQ(stored->attempts, 1);

  v1::LeaseTaskResponse again;
  ASSERT_TRUE(Lease(second, 0, &again).ok());
  ASSERT_TRUE(again.has_task());
  EXPECT_EQ(again.task().id(), task);

  // A failure of the worker's own environment: queued again, the attempt
  // given back, counted apart, said so.
  v1::TaskUpdate own = Update(second, task);
  own.set_failed("/cache/bundles/x.tar: cannot write the bundle (disk full?)");
  own.set_worker_fault(true);
  ASSERT_TRUE(Report({own}, &ack).ok());
  stored = jobs_->GetTask(task);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, store::TaskState::kQueued);
  EXPECT_EQ(stored->attempts, 1);  // the first worker's failure only
  EXPECT_EQ(stored->worker_faults, 1);
  EXPECT_EQ(stored->error, "/cache/bundles/x.tar: cannot write the bundle (disk full?) (on worker " + second +
                               " \"second\", a failure of the worker's own environment)");
}

TEST_F(WorkersServiceTest, PermanentFailureFailsTheJobWithoutAnotherAttempt) {
  Start();
  const std::string first = Register("first");
  const auto [job, task] = AddJob(SampleRequest().SerializeAsString());
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(first, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  v1::TaskUpdate failed = Update(first, task);
  failed.set_failed("options.atlas_size: must be in [16, 16384], got 5");
  failed.set_permanent(true);
  v1::TaskUpdateAck ack;
  ASSERT_TRUE(Report({failed}, &ack).ok());
  auto stored = jobs_->GetTask(task);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, store::TaskState::kFailed);
  EXPECT_EQ(stored->attempts, 1);
  auto ended = jobs_->GetJob(job);
  ASSERT_TRUE(ended.ok());
  EXPECT_EQ(ended->state, store::JobState::kFailed);
  EXPECT_NE(ended->error.find("options.atlas_size"), std::string::npos) << ended->error;
}

TEST_F(WorkersServiceTest, StopAnswersParkedPolls) {
  Start();
  const std::string worker = Register("w");
  v1::LeaseTaskResponse response;
  grpc::Status status;
  const auto start = steady_clock::now();
  std::thread poll([&] { status = Lease(worker, 10, &response); });
  std::this_thread::sleep_for(milliseconds(200));
  service_->Stop();
  poll.join();
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(response.has_task());
  EXPECT_LT(steady_clock::now() - start, std::chrono::seconds(2));
}

TEST_F(WorkersServiceTest, LeasedTaskCarriesItsDependenciesResultsAndStartedMs) {
  Start();
  const std::string worker = Register("w");
  auto job = jobs_->CreateJob(store::NewJob{"alice", std::string(64, 'a'), SampleRequest().SerializeAsString()},
                              now_ms_);
  ASSERT_TRUE(job.ok());
  auto key = jobs_->AddTask(store::NewTask{*job, "sweep", "key", std::nullopt, 0}, now_ms_);
  auto fill = jobs_->AddTask(store::NewTask{*job, "sweep", "key+fill", std::nullopt, 0}, now_ms_);
  ASSERT_TRUE(key.ok() && fill.ok());
  auto choose = jobs_->AddTask(store::NewTask{*job, "choose", "", store::TaskIds{*fill, *key}, 0}, now_ms_);
  ASSERT_TRUE(choose.ok());
  ASSERT_TRUE(jobs_->SealJob(*job, now_ms_).ok());

  for (const auto& [task, row] : {std::pair{*key, "row-key"}, std::pair{*fill, "row-fill"}}) {
    now_ms_ += 1000;
    v1::LeaseTaskResponse leased;
    ASSERT_TRUE(Lease(worker, 0, &leased).ok());
    ASSERT_TRUE(leased.has_task());
    EXPECT_EQ(leased.task().id(), task);
    EXPECT_EQ(leased.task().inputs_size(), 0);
    EXPECT_EQ(jobs_->GetTask(task)->started_ms, now_ms_.load());
    now_ms_ += 2500;
    v1::TaskUpdate result = Update(worker, task);
    result.set_result(row);
    v1::TaskUpdateAck ack;
    ASSERT_TRUE(Report({result}, &ack).ok());
    ASSERT_TRUE(ack.accepted());
    auto done = jobs_->GetTask(task);
    EXPECT_EQ(done->updated_ms - done->started_ms, 2500);
  }
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), *choose);
  // In dependency order, not completion order.
  ASSERT_EQ(leased.task().inputs_size(), 2);
  EXPECT_EQ(leased.task().inputs(0).task_id(), *fill);
  EXPECT_EQ(leased.task().inputs(0).kind(), "sweep");
  EXPECT_EQ(leased.task().inputs(0).key(), "key+fill");
  EXPECT_EQ(leased.task().inputs(0).result(), "row-fill");
  EXPECT_EQ(leased.task().inputs(1).task_id(), *key);
  EXPECT_EQ(leased.task().inputs(1).result(), "row-key");
}

TEST_F(WorkersServiceTest, GatheredSamplesAreCachedAndAnswerTheNextJobOnTheSameBundle) {
  Start();
  const std::string worker = Register("w");
  const auto [job1, gather1, sweep1] = AddGatherJob();

  // First job: a miss, the worker resamples and sends the Samples.
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), gather1);
  EXPECT_EQ(leased.task().inputs_size(), 0);
  const std::string encoded = EncodedSamples(100);
  const std::string sha256 = store::Sha256Hex(encoded);
  v1::TaskUpdateAck ack;
  grpc::Status status = Report(GatherUpdates(worker, gather1, encoded, 700, sha256), &ack);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(ack.accepted());
  EXPECT_FALSE(jobs_->GetTask(gather1)->samples_from_cache);
  const store::SampleKey key = TriangleSampleKey(std::string(64, 'a'), SampleRequest());
  auto cached = samples_->Get(key, now_ms_);
  ASSERT_TRUE(cached.ok()) << cached.status();
  ASSERT_TRUE(cached->has_value());
  EXPECT_EQ(**cached, encoded);
  // Pinned for the job (issue #17): its Samples and its cameras stay cached
  // until it has ended, whatever else is put meanwhile.
  const auto pins_of = [this](const std::string& job) {
    auto db = store::SqliteDb::Open(dir_.db());
    if (!db.ok()) return int64_t{-1};
    auto count = store::Statement::Prepare(**db, "SELECT COUNT(*) FROM sample_cache_pins WHERE job_id = ?1");
    if (!count.ok() || !count->BindText(1, job).ok() || !count->Step().ok()) return int64_t{-1};
    return count->ColumnInt64(0);
  };
  EXPECT_EQ(pins_of(job1), 2);

  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), sweep1);
  ASSERT_EQ(leased.task().inputs_size(), 1);
  EXPECT_EQ(leased.task().inputs(0).kind(), "gather");
  v1::GatherResult first;
  ASSERT_TRUE(first.ParseFromString(leased.task().inputs(0).result()));
  EXPECT_EQ(first.samples_sha256(), sha256);
  EXPECT_FALSE(first.from_cache());
  EXPECT_FALSE(jobs_->GetTask(sweep1)->samples_from_cache);
  const Fetched fetched = FetchSamples(worker, sweep1);
  ASSERT_TRUE(fetched.status.ok()) << fetched.status.error_message();
  EXPECT_EQ(fetched.bytes, encoded);
  EXPECT_EQ(fetched.sha256, sha256);
  EXPECT_EQ(fetched.total_size, encoded.size());

  // Second job on the same bundle: its gather is answered from the cache
  // and the worker gets the sweep right away.
  const auto [job2, gather2, sweep2] = AddGatherJob();
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), sweep2);
  ASSERT_EQ(leased.task().inputs_size(), 1);
  v1::GatherResult second;
  ASSERT_TRUE(second.ParseFromString(leased.task().inputs(0).result()));
  EXPECT_TRUE(second.from_cache());
  EXPECT_EQ(second.samples_sha256(), sha256);
  EXPECT_EQ(second.samples(), 100u);
  EXPECT_EQ(second.encoded_bytes(), encoded.size());
  // The cameras the Samples were resampled with come back with them (issue #14).
  EXPECT_EQ(second.calibration().cameras_decision(), "refined for the test");
  auto gather2_row = jobs_->GetTask(gather2);
  ASSERT_TRUE(gather2_row.ok());
  EXPECT_EQ(gather2_row->state, store::TaskState::kDone);
  EXPECT_EQ(gather2_row->lease_owner, worker);
  EXPECT_TRUE(gather2_row->samples_from_cache);
  EXPECT_TRUE(jobs_->GetTask(sweep2)->samples_from_cache);
  EXPECT_EQ(pins_of(job2), 2);  // a cache hit pins them for its job too

  const std::vector<v1::JobEvent> events = service_->RecordedEvents(job2);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].stage_started().stage(), "gather");
  EXPECT_EQ(events[0].stage_started().task_id(), gather2);
  EXPECT_EQ(events[1].stage_finished().stage(), "gather");
  EXPECT_DOUBLE_EQ(events[1].stage_finished().metrics().at("samples_from_cache"), 1.0);
  EXPECT_EQ(events[2].stage_started().task_id(), sweep2);
}

TEST_F(WorkersServiceTest, CorruptCacheEntryIsAMissAndTheWorkerResamples) {
  cache_options_.memory_bytes = 0;  // the bytes on disk are read, not the copy Put kept
  Start();
  const std::string worker = Register("w");
  const store::SampleKey key = TriangleSampleKey(std::string(64, 'a'), SampleRequest());
  ASSERT_TRUE(samples_->Put(key, EncodedSamples(10), now_ms_).ok());
  {
    auto db = store::SqliteDb::Open(dir_.db());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)->Exec("UPDATE sample_cache SET data = x'00112233'").ok());
  }
  const auto [job, gather, sweep] = AddGatherJob();
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), gather);
  EXPECT_FALSE(jobs_->GetTask(gather)->samples_from_cache);
  auto gone = samples_->Get(key, now_ms_);
  ASSERT_TRUE(gone.ok()) << gone.status();
  EXPECT_FALSE(gone->has_value());  // dropped
}

// Issue #14: Samples without the camera refinement they were resampled with
// are a miss (the later tasks would not know the cameras): the worker
// resamples.
TEST_F(WorkersServiceTest, CachedSamplesWithoutTheirCalibrationAreAMiss) {
  Start();
  const std::string worker = Register("w");
  ASSERT_TRUE(
      samples_->Put(TriangleSampleKey(std::string(64, 'a'), SampleRequest()), EncodedSamples(10), now_ms_).ok());
  const auto [job, gather, sweep] = AddGatherJob();
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), gather);
  EXPECT_FALSE(jobs_->GetTask(gather)->samples_from_cache);
}

// Intact bytes (the checksum holds) of an outdated encoding: a sample set
// of encoding version 1 (dense rows, at most 16 lights), which this build
// refuses (DATA_LOSS). The cache entry is a miss, dropped, and the gather
// task goes to a worker to resample; the job does not fail.
TEST_F(WorkersServiceTest, OutdatedEncodingInTheCacheIsAMissAndTheWorkerResamples) {
  Start();
  const std::string worker = Register("w");
  const store::SampleKey key = TriangleSampleKey(std::string(64, 'a'), SampleRequest());
  // Version 1: magic, version 1, flags compact, 1 light, 1 sample; the light
  // "A" (intensity 0); element, frame, camera, reflectance, g and h.
  std::string outdated("MVSS\x01\0\0\0\x01\0\0\0\x01\0\0\0\x01\0\0\0\0\0\0\0", 24);
  outdated += std::string("\x01\0\0\0A", 5) + std::string(12, '\0') + std::string(4 + 2 + 1 + 2 * (3 + 2), '\0');
  ASSERT_EQ(samples::DecodeSampleSet(outdated).status().code(), absl::StatusCode::kDataLoss);
  ASSERT_TRUE(samples_->Put(key, outdated, now_ms_).ok());
  const auto [job, gather, sweep] = AddGatherJob();
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_TRUE(leased.has_task());
  EXPECT_EQ(leased.task().id(), gather);
  EXPECT_FALSE(jobs_->GetTask(gather)->samples_from_cache);
  auto gone = samples_->Get(key, now_ms_);
  ASSERT_TRUE(gone.ok()) << gone.status();
  EXPECT_FALSE(gone->has_value());  // dropped
  // The current encoding of the same key answers the next job from the cache.
  ASSERT_TRUE(samples_->Put(key, EncodedSamples(10), now_ms_).ok());
  auto current = samples_->Get(key, now_ms_);
  ASSERT_TRUE(current.ok() && current->has_value());
  EXPECT_TRUE(samples::DecodeSampleSet(**current).ok());
}

TEST_F(WorkersServiceTest, GatherResultNeedsTheSamplesWithTheirSha256) {
  Start();
  const std::string worker = Register("w");
  const auto [job, gather, sweep] = AddGatherJob();
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), gather);
  const std::string encoded = EncodedSamples(20);

  // The result alone.
  std::vector<v1::TaskUpdate> updates = GatherUpdates(worker, gather, encoded, encoded.size(), "");
  v1::TaskUpdateAck ack;
  grpc::Status status = Report({updates.back()}, &ack);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("samples: a gather result needs the encoded Samples first"),
            std::string::npos)
      << status.error_message();

  // A result naming other Samples.
  status = Report(GatherUpdates(worker, gather, encoded, 64, std::string(64, 'f')), &ack);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("samples_sha256"), std::string::npos) << status.error_message();

  // Samples that do not hash to what their first chunk said.
  updates = GatherUpdates(worker, gather, encoded, 64, store::Sha256Hex(encoded));
  updates[0].mutable_samples()->set_sha256(std::string(64, '0'));
  status = Report(updates, &ack);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DATA_LOSS);

  // Samples from a task that is not a gather.
  const auto [other_job, other_sweep] = AddJob(SampleRequest().SerializeAsString());
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), other_sweep);
  updates = GatherUpdates(worker, other_sweep, encoded, 64, store::Sha256Hex(encoded));
  status = Report({updates[0]}, &ack);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("only a gather task"), std::string::npos) << status.error_message();

  auto row = jobs_->GetTask(gather);
  EXPECT_EQ(row->state, store::TaskState::kLeased);  // nothing accepted
  auto missing = samples_->Get(TriangleSampleKey(std::string(64, 'a'), SampleRequest()), now_ms_);
  ASSERT_TRUE(missing.ok());
  EXPECT_FALSE(missing->has_value());
}

TEST_F(WorkersServiceTest, FetchBundleStreamsTheCompleteBundle) {
  Start();
  const std::string worker = Register("w");
  std::string bundle((int64_t{5} << 19) + 123, '\0');  // 2.5 MiB + 123: three chunks
  for (size_t i = 0; i < bundle.size(); ++i) bundle[i] = static_cast<char>(i * 31 % 253);
  const std::string sha256 = store::Sha256Hex(bundle);
  std::filesystem::create_directories(dir_.path() / "bundles");
  {
    std::ofstream out(BundlePath(sha256), std::ios::binary);
    out.write(bundle.data(), static_cast<std::streamsize>(bundle.size()));
  }
  const Fetched fetched = FetchBundle(worker, sha256);
  ASSERT_TRUE(fetched.status.ok()) << fetched.status.error_message();
  EXPECT_EQ(fetched.chunks, 3);
  EXPECT_EQ(fetched.sha256, sha256);
  EXPECT_EQ(fetched.total_size, bundle.size());
  EXPECT_TRUE(fetched.bytes == bundle);

  EXPECT_EQ(FetchBundle(worker, std::string(64, 'e')).status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(FetchBundle(worker, "../../etc/passwd").status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(FetchBundle("nobody", sha256).status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(WorkersServiceTest, FetchSamplesServesTheLeaseHolderOnly) {
  Start();
  const std::string worker = Register("w");
  const std::string other = Register("other");
  const auto [job, gather, sweep] = AddGatherJob();
  // Not leased yet: nobody may fetch for it.
  EXPECT_EQ(FetchSamples(worker, sweep).status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(FetchSamples(worker, "no-such-task").status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(FetchSamples("nobody", sweep).status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), gather);
  const std::string encoded = EncodedSamples(50);
  v1::TaskUpdateAck ack;
  ASSERT_TRUE(Report(GatherUpdates(worker, gather, encoded, 700, store::Sha256Hex(encoded)), &ack).ok());
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), sweep);
  const Fetched taken = FetchSamples(other, sweep);
  EXPECT_EQ(taken.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(taken.status.error_message().find("not leased by worker"), std::string::npos)
      << taken.status.error_message();
  EXPECT_TRUE(FetchSamples(worker, sweep).status.ok());
  ASSERT_TRUE(jobs_->CancelJob(job, now_ms_).ok());
  EXPECT_EQ(FetchSamples(worker, sweep).status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

// Samples lost between the gather and a sweep (evicted, or corrupt and
// dropped): the gather runs again, the sweep waits behind it, and the job
// goes on; no attempt of the sweep is spent.
TEST_F(WorkersServiceTest, LostSamplesAreGatheredAgain) {
  cache_options_.memory_bytes = 0;  // the bytes on disk are read, not the copy Put kept
  Start();
  const std::string worker = Register("w");
  const auto [job, gather, sweep] = AddGatherJob();
  const std::string encoded = EncodedSamples(50);
  const std::string sha256 = store::Sha256Hex(encoded);
  const store::SampleKey key = TriangleSampleKey(std::string(64, 'a'), SampleRequest());
  for (const bool corrupt : {false, true}) {
    SCOPED_TRACE(corrupt ? "corrupt" : "evicted");
    v1::LeaseTaskResponse leased;
    ASSERT_TRUE(Lease(worker, 0, &leased).ok());
    ASSERT_EQ(leased.task().id(), gather);
    v1::TaskUpdateAck ack;
    ASSERT_TRUE(Report(GatherUpdates(worker, gather, encoded, 700, sha256), &ack).ok());
    ASSERT_TRUE(Lease(worker, 0, &leased).ok());
    ASSERT_EQ(leased.task().id(), sweep);
    if (corrupt) {
      // Flip one byte of the stored blob behind the cache's back.
      auto db = store::SqliteDb::Open(dir_.db());
      ASSERT_TRUE(db.ok());
      auto read = store::Statement::Prepare(**db, "SELECT data FROM sample_cache");
      ASSERT_TRUE(read.ok());
      ASSERT_TRUE(read->Step().ok());
      std::string data = read->ColumnBlob(0);
      ASSERT_FALSE(data.empty());
      data[data.size() / 2] = static_cast<char>(data[data.size() / 2] ^ 0x5a);
      auto write = store::Statement::Prepare(**db, "UPDATE sample_cache SET data = ?1");
      ASSERT_TRUE(write.ok());
      ASSERT_TRUE(write->BindBlob(1, data).ok());
      ASSERT_TRUE(write->Run().ok());
    } else {
      ASSERT_TRUE(samples_->Erase(key).ok());
    }
    const Fetched lost = FetchSamples(worker, sweep);
    EXPECT_EQ(lost.status.error_code(), grpc::StatusCode::ABORTED) << lost.status.error_message();
    EXPECT_NE(lost.status.error_message().find("gathering again"), std::string::npos) << lost.status.error_message();
    EXPECT_EQ(jobs_->GetTask(gather)->state, store::TaskState::kQueued);
    EXPECT_EQ(jobs_->GetTask(sweep)->state, store::TaskState::kQueued);
    EXPECT_EQ(jobs_->GetTask(sweep)->attempts, 0);
    auto entry = samples_->Get(key, now_ms_);
    ASSERT_TRUE(entry.ok()) << entry.status();
    EXPECT_FALSE(entry->has_value()) << "the lost entry is still cached";
  }
  // Third time round the Samples stay: the sweep gets them and the job goes on.
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), gather);
  EXPECT_EQ(jobs_->GetTask(gather)->attempts, 3);
  v1::TaskUpdateAck ack;
  ASSERT_TRUE(Report(GatherUpdates(worker, gather, encoded, 700, sha256), &ack).ok());
  ASSERT_TRUE(Lease(worker, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), sweep);
  const Fetched fetched = FetchSamples(worker, sweep);
  ASSERT_TRUE(fetched.status.ok()) << fetched.status.error_message();
  EXPECT_EQ(fetched.bytes, encoded);
  EXPECT_EQ(jobs_->GetTask(sweep)->attempts, 1);
  EXPECT_EQ(jobs_->GetJob(job)->state, store::JobState::kRunning);
}

// Issue #17: the sweeps fetch the Samples the gather has just stored from the
// copy the cache keeps in memory, not by reading, inflating and hashing them
// again; without that copy (memory 0) every fetch reads the database.
class SampleFetchTest : public WorkersServiceTest, public ::testing::WithParamInterface<int64_t> {};

TEST_P(SampleFetchTest, TwoWorkersFetchTheGatheredSamples) {
  cache_options_.memory_bytes = GetParam();
  Start();
  const std::string first = Register("first"), second = Register("second");
  v1::SubmitJobRequest request = SampleRequest();
  request.set_bundle_sha256(std::string(64, 'a'));
  auto job = jobs_->CreateJob(store::NewJob{"alice", std::string(64, 'a'), request.SerializeAsString()}, now_ms_);
  ASSERT_TRUE(job.ok()) << job.status();
  auto gather = jobs_->AddTask(store::NewTask{*job, "gather", "", std::nullopt, 0}, now_ms_);
  ASSERT_TRUE(gather.ok()) << gather.status();
  for (const char* key : {"key", "key+fill"}) {
    ASSERT_TRUE(jobs_->AddTask(store::NewTask{*job, "sweep", key, *gather, 0}, now_ms_).ok());
  }
  ASSERT_TRUE(jobs_->SealJob(*job, now_ms_).ok());
  const std::string encoded = EncodedSamples(200);
  const std::string sha256 = store::Sha256Hex(encoded);
  v1::LeaseTaskResponse leased;
  ASSERT_TRUE(Lease(first, 0, &leased).ok());
  ASSERT_EQ(leased.task().id(), *gather);
  v1::TaskUpdateAck ack;
  ASSERT_TRUE(Report(GatherUpdates(first, *gather, encoded, 700, sha256), &ack).ok());
  for (const std::string& worker : {first, second}) {
    ASSERT_TRUE(Lease(worker, 0, &leased).ok());
    ASSERT_TRUE(leased.has_task());
    ASSERT_EQ(leased.task().kind(), "sweep");
    const Fetched fetched = FetchSamples(worker, leased.task().id());
    ASSERT_TRUE(fetched.status.ok()) << fetched.status.error_message();
    EXPECT_EQ(fetched.bytes, encoded);
    EXPECT_EQ(fetched.sha256, sha256);
  }
  auto stats = samples_->Stats();
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_EQ(stats->hits, 2);
  EXPECT_EQ(stats->memory_hits, GetParam() > 0 ? 2 : 0);
}

INSTANTIATE_TEST_SUITE_P(MemoryBytes, SampleFetchTest, ::testing::Values(int64_t{256} << 20, int64_t{0}));

}  // namespace
}  // namespace mvbrdf::server
