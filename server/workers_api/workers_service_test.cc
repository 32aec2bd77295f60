// WorkersService over a real gRPC channel (loopback, port chosen by the OS),
// an in-process server, real SQLite stores in a temporary directory and a
// fake clock for leases.
#include "server/workers_api/workers_service.h"

#include <atomic>
#include <chrono>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "server/store/digest.h"
#include "server/store/test_dir.h"

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
    service_ = std::make_unique<WorkersService>(
        *jobs_, *artifacts_, [this] { return now_ms_.load(); }, options, [this](const v1::JobEvent& event) {
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

  store::TestDir dir_;
  std::atomic<int64_t> now_ms_{kT0};
  std::unique_ptr<store::JobStore> jobs_;
  std::unique_ptr<store::ArtifactStore> artifacts_;
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
  const auto [job, task] = AddJob(std::string("\xff\xff\xff not a proto", 17));
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
  EXPECT_EQ(stored->error, "EGL: no display");

  v1::LeaseTaskResponse again;
  ASSERT_TRUE(Lease(second, 0, &again).ok());
  ASSERT_TRUE(again.has_task());
  EXPECT_EQ(again.task().id(), task);
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

}  // namespace
}  // namespace mvbrdf::server
