// The server's security over real gRPC channels (issue #7): an in-process
// server::Server started from a tokens file and, for TLS, certificates that
// `openssl` makes at test time (never committed); each role against each
// method of both services, job ownership between clients, health checking
// open, TLS and mutual TLS, and every configurable limit.
#include <gmock/gmock.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "core/base/files.h"
#include "core/bundle/bundle.h"
#include "core/gl/egl_context.h"
#include "core/synth/synthesizer.h"
#include "mvbrdf/v1/service.grpc.pb.h"
#include "server/process/server.h"
#include "server/store/test_dir.h"

namespace mvbrdf::server {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kAlice[] = "alice-token-0123456789abcdef";
constexpr char kBob[] = "bob-token-0123456789abcdef";
constexpr char kWorker[] = "worker-token-0123456789abcdef";
constexpr char kOtherWorker[] = "other-worker-token-0123456789";
constexpr char kAdmin[] = "admin-token-0123456789abcdef";
constexpr char kWrong[] = "nobody-token-0123456789abcdef";
// Plaintext against a TLS port (and a wrong CA) fails, but only once the
// deadline is over: short.
constexpr int kFailingCallSeconds = 3;
constexpr int kCallSeconds = 20;

std::chrono::system_clock::time_point Deadline(int seconds = kCallSeconds) {
  return std::chrono::system_clock::now() + std::chrono::seconds(seconds);
}

// Runs `command` in a shell; the test fails when it does.
void Shell(const std::string& command) {
  const int rc = std::system(command.c_str());
  ASSERT_EQ(rc, 0) << command;
}

// A context with "authorization: Bearer <token>" (none for an empty token).
std::unique_ptr<grpc::ClientContext> WithToken(const std::string& token, int seconds = kCallSeconds) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(Deadline(seconds));
  if (!token.empty()) context->AddMetadata("authorization", std::string("Bearer ") + token);
  return context;
}

// One call of each method, with `context`, with a harmless request; returns
// the call's status.
using Call = std::function<grpc::Status(grpc::ClientContext&)>;

std::vector<std::pair<std::string, Call>> ClientMethods(v1::Mvbrdf::Stub& stub) {
  return {
      {"UploadBundle",
       [&stub](grpc::ClientContext& c) {
         v1::UploadStatus status;
         auto writer = stub.UploadBundle(&c, &status);
         v1::UploadChunk chunk;
         chunk.set_sha256(std::string(64, 'a'));
         chunk.set_total_size(10);
         writer->Write(chunk);
         writer->WritesDone();
         return writer->Finish();
       }},
      {"QueryUpload",
       [&stub](grpc::ClientContext& c) {
         v1::QueryUploadRequest request;
         request.set_sha256(std::string(64, 'a'));
         v1::UploadStatus status;
         return stub.QueryUpload(&c, request, &status);
       }},
      {"SubmitJob",
       [&stub](grpc::ClientContext& c) {
         v1::SubmitJobRequest request;
         request.set_bundle_sha256(std::string(64, 'a'));
         v1::SubmitJobResponse response;
         return stub.SubmitJob(&c, request, &response);
       }},
      {"WatchJob",
       [&stub](grpc::ClientContext& c) {
         v1::WatchJobRequest request;
         request.set_job_id("no-such-job");
         auto reader = stub.WatchJob(&c, request);
         v1::JobEvent event;
         while (reader->Read(&event)) {
         }
         return reader->Finish();
       }},
      {"FetchArtifact",
       [&stub](grpc::ClientContext& c) {
         v1::FetchArtifactRequest request;
         request.set_job_id("no-such-job");
         request.set_name("result.json");
         auto reader = stub.FetchArtifact(&c, request);
         v1::ArtifactChunk chunk;
         while (reader->Read(&chunk)) {
         }
         return reader->Finish();
       }},
      {"ListArtifacts",
       [&stub](grpc::ClientContext& c) {
         v1::ListArtifactsRequest request;
         request.set_job_id("no-such-job");
         v1::ListArtifactsResponse response;
         return stub.ListArtifacts(&c, request, &response);
       }},
      {"CancelJob",
       [&stub](grpc::ClientContext& c) {
         v1::CancelJobRequest request;
         request.set_job_id("no-such-job");
         v1::Job job;
         return stub.CancelJob(&c, request, &job);
       }},
      {"ListJobs",
       [&stub](grpc::ClientContext& c) {
         v1::ListJobsResponse response;
         return stub.ListJobs(&c, v1::ListJobsRequest(), &response);
       }},
  };
}

std::vector<std::pair<std::string, Call>> WorkerMethods(v1::Workers::Stub& stub) {
  return {
      {"RegisterWorker",
       [&stub](grpc::ClientContext& c) {
         v1::RegisterWorkerRequest request;
         request.set_name("w");
         v1::RegisterWorkerResponse response;
         return stub.RegisterWorker(&c, request, &response);
       }},
      {"LeaseTask",
       [&stub](grpc::ClientContext& c) {
         v1::LeaseTaskRequest request;
         request.set_worker_id("unknown");
         v1::LeaseTaskResponse response;
         return stub.LeaseTask(&c, request, &response);
       }},
      {"RenewLease",
       [&stub](grpc::ClientContext& c) {
         v1::RenewLeaseRequest request;
         request.set_worker_id("unknown");
         request.set_task_id("t");
         v1::RenewLeaseResponse response;
         return stub.RenewLease(&c, request, &response);
       }},
      {"ReportTask",
       [&stub](grpc::ClientContext& c) {
         v1::TaskUpdateAck ack;
         auto writer = stub.ReportTask(&c, &ack);
         v1::TaskUpdate update;
         update.set_worker_id("unknown");
         update.set_task_id("t");
         writer->Write(update);
         writer->WritesDone();
         return writer->Finish();
       }},
      {"FetchBundle",
       [&stub](grpc::ClientContext& c) {
         v1::FetchBundleRequest request;
         request.set_worker_id("unknown");
         request.set_sha256(std::string(64, 'a'));
         auto reader = stub.FetchBundle(&c, request);
         v1::ArtifactChunk chunk;
         while (reader->Read(&chunk)) {
         }
         return reader->Finish();
       }},
      {"FetchSamples",
       [&stub](grpc::ClientContext& c) {
         v1::FetchSamplesRequest request;
         request.set_worker_id("unknown");
         request.set_task_id("t");
         auto reader = stub.FetchSamples(&c, request);
         v1::ArtifactChunk chunk;
         while (reader->Read(&chunk)) {
         }
         return reader->Finish();
       }},
  };
}

// grpc.health.v1.Health/Check for the whole server, with no metadata.
grpc::Status HealthCheck(const std::shared_ptr<grpc::Channel>& channel, int seconds = kCallSeconds) {
  grpc::GenericStub generic(channel);
  grpc::ClientContext context;
  context.set_deadline(Deadline(seconds));
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&done](grpc::Status s) { done.set_value(s); });
  return done.get_future().get();
}

// The service names reflection lists, asked with no metadata (one
// ServerReflectionInfo exchange: list_services = "*").
std::string ReflectionListing(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub generic(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext context;
  context.set_deadline(Deadline());
  auto call = generic.PrepareCall(&context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  void* tag = nullptr;
  bool ok = false;
  // Each step waits for its own completion before the next starts.
  auto step = [&](int id) { return cq.Next(&tag, &ok) && tag == reinterpret_cast<void*>(id) && ok; };
  call->StartCall(reinterpret_cast<void*>(1));
  if (!step(1)) return "";
  grpc::Slice list_all(std::string("\x3a\x01*", 3));  // field 7 (list_services) = "*"
  grpc::ByteBuffer request(&list_all, 1), response;
  call->Write(request, reinterpret_cast<void*>(2));
  if (!step(2)) return "";
  call->Read(&response, reinterpret_cast<void*>(3));
  if (!step(3)) return "";
  call->WritesDone(reinterpret_cast<void*>(4));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  step(5);
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return "";
  std::string bytes;
  for (const grpc::Slice& slice : slices) bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  return bytes;
}

class SecurityTest : public ::testing::Test {
 protected:
  // Once for the suite: a small synthetic scene (2 cameras, 2 frames) packed
  // as a bundle; a CA, a server certificate for localhost/127.0.0.1 and a
  // client certificate signed by it; a second, unrelated CA.
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("mvbrdf_security_test_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
    ASSERT_TRUE(context.ok()) << context.status();
    synth::SynthOptions o;
    o.num_cameras = 2;
    o.num_frames = 2;
    o.width = 64;
    o.height = 48;
    o.actor_segments = 8;
    o.shadow_map_size = 256;
    o.noise_sigma = 0.0;
    o.out_dir = *dir_ / "scene";
    auto scene = synth::Synthesize(o, **context);
    ASSERT_TRUE(scene.ok()) << scene.status();
    auto info = bundle::PackBundle(scene->scene_file, *dir_ / "scene.tar");
    ASSERT_TRUE(info.ok()) << info.status();
    auto bytes = ReadFileToString(*dir_ / "scene.tar");
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    bundle_ = new std::string(*bytes);
    bundle_sha256_ = new std::string(info->sha256);

    const std::string d = dir_->string();
    // openssl prints its progress on stderr: keep the test log readable.
    const std::string q = " 2>/dev/null";
    for (const char* ca : {"ca", "other_ca"}) {
      Shell("openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=" + std::string(ca) + " -keyout " + d + "/" +
            ca + ".key -out " + d + "/" + ca + ".pem" + q);
    }
    Shell("printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\\n' > " + d + "/san.ext");
    Shell("openssl req -newkey rsa:2048 -nodes -subj /CN=localhost -keyout " + d + "/server.key -out " + d +
          "/server.csr" + q);
    Shell("openssl x509 -req -in " + d + "/server.csr -CA " + d + "/ca.pem -CAkey " + d +
          "/ca.key -CAcreateserial -days 2 -extfile " + d + "/san.ext -out " + d + "/server.pem" + q);
    Shell("openssl req -newkey rsa:2048 -nodes -subj /CN=client -keyout " + d + "/client.key -out " + d +
          "/client.csr" + q);
    Shell("openssl x509 -req -in " + d + "/client.csr -CA " + d + "/ca.pem -CAkey " + d +
          "/ca.key -CAcreateserial -days 2 -out " + d + "/client.pem" + q);
    // The tokens file: alice's token as its SHA-256 (the file need not hold
    // the secret), the others in clear.
    Shell("printf 'client alice sha256:%s\\n' $(printf %s " + std::string(kAlice) + " | sha256sum | cut -c1-64) > " +
          d + "/tokens.txt");
    Shell("printf '# role name token\\nclient bob " + std::string(kBob) + "\\nworker gpu-1 " + kWorker +
          "\\nworker gpu-2 " + kOtherWorker + "\\nadmin ops " + kAdmin + "\\n' >> " + d + "/tokens.txt");
  }
  static void TearDownTestSuite() {
    if (dir_ != nullptr) fs::remove_all(*dir_);
    delete dir_;
    delete bundle_;
    delete bundle_sha256_;
  }

  static std::string Pem(const std::string& name) {
    auto text = ReadFileToString(*dir_ / name);
    EXPECT_TRUE(text.ok()) << text.status();
    return text.ok() ? *text : "";
  }

  // Options of a server with tokens on a loopback port of its own.
  ServerOptions Options() const {
    ServerOptions options;
    options.data_dir = data_.path() / "data";
    options.tokens_file = *dir_ / "tokens.txt";
    return options;
  }

  void Start(const ServerOptions& options) {
    auto server = Server::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
    clients_ = v1::Mvbrdf::NewStub(channel_);
    workers_ = v1::Workers::NewStub(channel_);
  }

  // Uploads the scene bundle in 100 KiB chunks as `token`.
  void UploadScene(const std::string& token) {
    auto context = WithToken(token);
    v1::UploadStatus status;
    auto writer = clients_->UploadBundle(context.get(), &status);
    constexpr size_t kChunk = 100 << 10;
    for (size_t offset = 0; offset < bundle_->size(); offset += kChunk) {
      v1::UploadChunk chunk;
      if (offset == 0) {
        chunk.set_sha256(*bundle_sha256_);
        chunk.set_total_size(bundle_->size());
      }
      chunk.set_offset(offset);
      chunk.set_data(bundle_->substr(offset, kChunk));
      if (!writer->Write(chunk)) break;
    }
    writer->WritesDone();
    const grpc::Status s = writer->Finish();
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_TRUE(status.complete());
  }

  grpc::Status Submit(const std::string& token, v1::Job* job, uint32_t atlas_size = 0, const std::string& label = "") {
    auto context = WithToken(token);
    if (!label.empty()) context->AddMetadata("x-mvbrdf-client", label);
    v1::SubmitJobRequest request;
    request.set_bundle_sha256(*bundle_sha256_);
    request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
    request.mutable_options()->set_atlas_size(atlas_size);
    v1::SubmitJobResponse response;
    const grpc::Status s = clients_->SubmitJob(context.get(), request, &response);
    if (job != nullptr) *job = response.job();
    return s;
  }

  grpc::Status Watch(const std::string& token, const std::string& job_id, int* events) {
    auto context = WithToken(token);
    v1::WatchJobRequest request;
    request.set_job_id(job_id);
    auto reader = clients_->WatchJob(context.get(), request);
    v1::JobEvent event;
    *events = 0;
    while (reader->Read(&event)) ++*events;
    return reader->Finish();
  }

  grpc::Status Fetch(const std::string& token, const std::string& job_id, const std::string& name, std::string* bytes) {
    auto context = WithToken(token);
    v1::FetchArtifactRequest request;
    request.set_job_id(job_id);
    request.set_name(name);
    auto reader = clients_->FetchArtifact(context.get(), request);
    v1::ArtifactChunk chunk;
    bytes->clear();
    while (reader->Read(&chunk)) *bytes += chunk.data();
    return reader->Finish();
  }

  grpc::Status Cancel(const std::string& token, const std::string& job_id) {
    auto context = WithToken(token);
    v1::CancelJobRequest request;
    request.set_job_id(job_id);
    v1::Job job;
    return clients_->CancelJob(context.get(), request, &job);
  }

  std::vector<std::string> ListJobIds(const std::string& token) {
    auto context = WithToken(token);
    v1::ListJobsResponse response;
    const grpc::Status s = clients_->ListJobs(context.get(), v1::ListJobsRequest(), &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
    std::vector<std::string> ids;
    for (const v1::Job& job : response.jobs()) ids.push_back(job.id());
    return ids;
  }

  static fs::path* dir_;
  static std::string* bundle_;
  static std::string* bundle_sha256_;
  store::TestDir data_;
  std::unique_ptr<Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::Mvbrdf::Stub> clients_;
  std::unique_ptr<v1::Workers::Stub> workers_;
};

fs::path* SecurityTest::dir_ = nullptr;
std::string* SecurityTest::bundle_ = nullptr;
std::string* SecurityTest::bundle_sha256_ = nullptr;

// Every method of both services against every kind of caller.
TEST_F(SecurityTest, EachRoleReachesOnlyItsService) {
  Start(Options());
  ASSERT_TRUE(server_->authenticating());
  const auto client_methods = ClientMethods(*clients_);
  const auto worker_methods = WorkerMethods(*workers_);
  std::vector<std::pair<std::string, Call>> all = client_methods;
  all.insert(all.end(), worker_methods.begin(), worker_methods.end());
  ASSERT_EQ(all.size(), 14u);

  for (const auto& [name, call] : all) {
    SCOPED_TRACE(name);
    // No token, an unknown token, a malformed header: UNAUTHENTICATED, with
    // what is expected and without the token.
    grpc::Status s = call(*WithToken(""));
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED) << s.error_message();
    EXPECT_THAT(s.error_message(), HasSubstr("authorization: Bearer <token>"));
    s = call(*WithToken(kWrong));
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED) << s.error_message();
    EXPECT_THAT(s.error_message(), Not(HasSubstr(kWrong)));
    auto lowercase = WithToken("");  // the scheme is case-insensitive, the token is not
    lowercase->AddMetadata("authorization", std::string("bearer ") + kWrong);
    s = call(*lowercase);
    EXPECT_THAT(s.error_message(), HasSubstr("the token is not known")) << s.error_message();
    auto basic = WithToken("");
    basic->AddMetadata("authorization", std::string("Basic ") + kAlice);
    s = call(*basic);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED) << s.error_message();
    EXPECT_THAT(s.error_message(), Not(HasSubstr(kAlice)));
    // An admin token passes authorisation everywhere (the harmless request
    // then fails, or not, for its own reasons).
    s = call(*WithToken(kAdmin));
    EXPECT_NE(s.error_code(), grpc::StatusCode::UNAUTHENTICATED) << s.error_message();
    EXPECT_NE(s.error_code(), grpc::StatusCode::PERMISSION_DENIED) << s.error_message();
  }
  for (const auto& [name, call] : client_methods) {
    SCOPED_TRACE(name);
    const grpc::Status denied = call(*WithToken(kWorker));
    EXPECT_EQ(denied.error_code(), grpc::StatusCode::PERMISSION_DENIED) << denied.error_message();
    EXPECT_THAT(denied.error_message(), HasSubstr("worker token \"gpu-1\" may not call mvbrdf.v1.Mvbrdf"));
    grpc::ClientContext lowercase;
    lowercase.set_deadline(Deadline());
    lowercase.AddMetadata("authorization", std::string("bearer ") + kAlice);
    const grpc::Status lower = call(lowercase);
    EXPECT_NE(lower.error_code(), grpc::StatusCode::UNAUTHENTICATED) << lower.error_message();
    const grpc::Status allowed = call(*WithToken(kAlice));
    EXPECT_NE(allowed.error_code(), grpc::StatusCode::UNAUTHENTICATED) << allowed.error_message();
    EXPECT_NE(allowed.error_code(), grpc::StatusCode::PERMISSION_DENIED) << allowed.error_message();
  }
  for (const auto& [name, call] : worker_methods) {
    SCOPED_TRACE(name);
    const grpc::Status denied = call(*WithToken(kBob));
    EXPECT_EQ(denied.error_code(), grpc::StatusCode::PERMISSION_DENIED) << denied.error_message();
    EXPECT_THAT(denied.error_message(), HasSubstr("client token \"bob\" may not call mvbrdf.v1.Workers"));
    const grpc::Status allowed = call(*WithToken(kWorker));
    EXPECT_NE(allowed.error_code(), grpc::StatusCode::UNAUTHENTICATED) << allowed.error_message();
    EXPECT_NE(allowed.error_code(), grpc::StatusCode::PERMISSION_DENIED) << allowed.error_message();
  }
  // Health checking and reflection need no token (probes, grpcurl).
  const grpc::Status health = HealthCheck(channel_);
  EXPECT_TRUE(health.ok()) << health.error_message();
  EXPECT_THAT(ReflectionListing(channel_), HasSubstr("mvbrdf.v1.Workers"));
}

// A client sees and acts on its own jobs only; the unauthenticated label
// changes nothing; an admin sees everything.
TEST_F(SecurityTest, ClientsCannotReachEachOthersJobs) {
  Start(Options());
  UploadScene(kAlice);
  v1::Job alice_job, bob_job;
  // The label would have made it "bob"'s without tokens.
  grpc::Status s = Submit(kAlice, &alice_job, 0, "bob");
  ASSERT_TRUE(s.ok()) << s.error_message();
  s = Submit(kBob, &bob_job);  // the same bundle: content-addressed, shared
  ASSERT_TRUE(s.ok()) << s.error_message();
  auto artifact = server_->artifacts().PutBytes(bob_job.id(), "result.json", "{\"bob\": 1}", 0);
  ASSERT_TRUE(artifact.ok()) << artifact.status();

  EXPECT_THAT(ListJobIds(kAlice), ::testing::ElementsAre(alice_job.id()));
  EXPECT_THAT(ListJobIds(kBob), ::testing::ElementsAre(bob_job.id()));
  EXPECT_THAT(ListJobIds(kAdmin), ::testing::ElementsAre(alice_job.id(), bob_job.id()));

  // Alice on Bob's job: NOT_FOUND, as if it did not exist.
  std::string bytes;
  s = Fetch(kAlice, bob_job.id(), "result.json", &bytes);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("no such job"));
  EXPECT_TRUE(bytes.empty());
  int events = 0;
  s = Watch(kAlice, bob_job.id(), &events);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND) << s.error_message();
  EXPECT_EQ(events, 0);
  s = Cancel(kAlice, bob_job.id());
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND) << s.error_message();
  EXPECT_EQ(server_->jobs().GetJob(bob_job.id())->state, store::JobState::kQueued);
  // A worker token cannot read client artifacts either.
  s = Fetch(kWorker, bob_job.id(), "result.json", &bytes);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::PERMISSION_DENIED) << s.error_message();

  // Bob on his own job, and the admin on anyone's.
  s = Fetch(kBob, bob_job.id(), "result.json", &bytes);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(bytes, "{\"bob\": 1}");
  s = Fetch(kAdmin, bob_job.id(), "result.json", &bytes);
  EXPECT_TRUE(s.ok()) << s.error_message();
  s = Cancel(kBob, bob_job.id());
  EXPECT_TRUE(s.ok()) << s.error_message();
  s = Watch(kBob, bob_job.id(), &events);  // a final job: its events, then the end
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_GT(events, 0);
  s = Cancel(kAdmin, alice_job.id());
  EXPECT_TRUE(s.ok()) << s.error_message();
}

TEST_F(SecurityTest, TokensFileErrorsStopTheServer) {
  ServerOptions options = Options();
  options.tokens_file = *dir_ / "missing_tokens.txt";
  auto server = Server::Start(options);
  EXPECT_EQ(server.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(server.status().message(), HasSubstr("--tokens-file"));
}

// Without tokens everything is as before: open, and the label is the client.
TEST_F(SecurityTest, NoTokensMeansNoAuthentication) {
  ServerOptions options = Options();
  options.tokens_file.clear();
  Start(options);
  EXPECT_FALSE(server_->authenticating());
  UploadScene("");
  v1::Job job;
  grpc::Status s = Submit("", &job, 0, "carol");
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(server_->jobs().GetJob(job.id())->client, "carol");
  auto context = WithToken("");
  v1::RegisterWorkerRequest request;
  request.set_name("w");
  v1::RegisterWorkerResponse response;
  s = workers_->RegisterWorker(context.get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
}

// TLS: a client trusting the CA connects; plaintext and a client trusting
// another CA do not. Mutual TLS: a client certificate is required.
TEST_F(SecurityTest, TlsOnlyWithTheRightCaAndMutualTlsNeedsAClientCertificate) {
  ServerOptions options = Options();
  options.tls_cert_file = *dir_ / "server.pem";
  options.tls_key_file = *dir_ / "server.key";
  Start(options);
  ASSERT_TRUE(server_->tls());
  const std::string port = server_->address().substr(server_->address().rfind(':') + 1);

  grpc::SslCredentialsOptions trusting;
  trusting.pem_root_certs = Pem("ca.pem");
  for (const std::string host : {"localhost", "127.0.0.1"}) {
    auto channel = grpc::CreateChannel(host + ":" + port, grpc::SslCredentials(trusting));
    EXPECT_TRUE(HealthCheck(channel).ok()) << host;
    auto stub = v1::Workers::NewStub(channel);
    auto context = WithToken(kWorker);
    v1::RegisterWorkerRequest request;
    request.set_name("tls-worker");
    v1::RegisterWorkerResponse response;
    const grpc::Status s = stub->RegisterWorker(context.get(), request, &response);
    EXPECT_TRUE(s.ok()) << host << ": " << s.error_message();
  }

  // Plaintext to the TLS port.
  const grpc::Status plain = HealthCheck(channel_, kFailingCallSeconds);
  EXPECT_FALSE(plain.ok());
  EXPECT_EQ(plain.error_code(), grpc::StatusCode::UNAVAILABLE) << plain.error_message();
  // TLS trusting another CA.
  grpc::SslCredentialsOptions other;
  other.pem_root_certs = Pem("other_ca.pem");
  const grpc::Status wrong_ca =
      HealthCheck(grpc::CreateChannel("localhost:" + port, grpc::SslCredentials(other)), kFailingCallSeconds);
  EXPECT_EQ(wrong_ca.error_code(), grpc::StatusCode::UNAVAILABLE) << wrong_ca.error_message();
  server_.reset();

  options.tls_client_ca_file = *dir_ / "ca.pem";
  Start(options);
  const std::string mutual_port = server_->address().substr(server_->address().rfind(':') + 1);
  const grpc::Status no_client_cert =
      HealthCheck(grpc::CreateChannel("localhost:" + mutual_port, grpc::SslCredentials(trusting)), kFailingCallSeconds);
  EXPECT_FALSE(no_client_cert.ok());
  grpc::SslCredentialsOptions with_cert = trusting;
  with_cert.pem_cert_chain = Pem("client.pem");
  with_cert.pem_private_key = Pem("client.key");
  const grpc::Status mutual =
      HealthCheck(grpc::CreateChannel("localhost:" + mutual_port, grpc::SslCredentials(with_cert)));
  EXPECT_TRUE(mutual.ok()) << mutual.error_message();
}

TEST_F(SecurityTest, TlsFilesThatAreNotPemStopTheServer) {
  ServerOptions options = Options();
  options.tls_cert_file = *dir_ / "tokens.txt";
  options.tls_key_file = *dir_ / "server.key";
  auto server = Server::Start(options);
  EXPECT_EQ(server.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(server.status().message(), HasSubstr("--tls-cert"));
}

// Each configurable limit refuses what exceeds it, naming the field.
TEST_F(SecurityTest, LimitsAreEnforced) {
  ServerOptions options = Options();
  options.limits.max_message_bytes = 256 << 10;
  options.limits.max_bundle_bytes = 16 << 20;
  options.limits.max_jobs_per_client = 1;
  options.limits.max_atlas_size = 1024;
  options.limits.max_frames = 2;  // the scene has 2
  Start(options);
  UploadScene(kAlice);

  // Atlas size: over the limit (RESOURCE_EXHAUSTED) and at it (accepted).
  v1::Job job;
  grpc::Status s = Submit(kAlice, &job, 100000);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(s.error_message(), "options.atlas_size: 100000 exceeds the server's limit 1024 (max_atlas_size)");
  s = Submit(kAlice, &job, 2048);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Jobs per client, counted by the token's principal whatever the label.
  s = Submit(kAlice, &job, 1024);
  ASSERT_TRUE(s.ok()) << s.error_message();
  s = Submit(kAlice, nullptr, 0, "someone-else");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("client \"alice\" has 1 unfinished jobs, the limit is 1"));
  s = Submit(kBob, nullptr);
  EXPECT_TRUE(s.ok()) << s.error_message();
  ASSERT_TRUE(Cancel(kAlice, job.id()).ok());
  s = Submit(kAlice, &job);
  EXPECT_TRUE(s.ok()) << s.error_message();

  // Bundle size: the declared total_size.
  {
    auto context = WithToken(kAlice);
    v1::UploadStatus status;
    auto writer = clients_->UploadBundle(context.get(), &status);
    v1::UploadChunk chunk;
    chunk.set_sha256(std::string(64, 'b'));
    chunk.set_total_size((16 << 20) + 1);
    writer->Write(chunk);
    writer->WritesDone();
    s = writer->Finish();
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_THAT(s.error_message(), HasSubstr("total_size"));
  }
  // Message size: gRPC refuses a message over the limit (plus headroom).
  {
    auto context = WithToken(kAlice);
    v1::QueryUploadRequest request;
    request.set_sha256(std::string(512 << 10, 'a'));
    v1::UploadStatus status;
    s = clients_->QueryUpload(context.get(), request, &status);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  }
  server_.reset();

  // Frames: the scene's 2 frames over a limit of 1.
  options.limits.max_frames = 1;
  options.limits.max_jobs_per_client = 0;
  Start(options);
  s = Submit(kAlice, nullptr);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(s.error_message(), "scene.frames.count: 2 frames exceed the server's limit 1 (max_frames)");
}

// The worker-side limits: an artifact or gather Samples declared larger than
// the server keeps are refused before any byte is held.
// A worker id is a handle, not a credential: another worker token cannot
// lease, renew or report as a worker it did not register.
TEST_F(SecurityTest, AWorkerIdWorksOnlyWithTheTokenThatRegisteredIt) {
  Start(Options());
  UploadScene(kAlice);
  ASSERT_TRUE(Submit(kAlice, nullptr).ok());
  v1::RegisterWorkerResponse registered;
  {
    auto context = WithToken(kWorker);
    v1::RegisterWorkerRequest request;
    request.set_name("w");
    ASSERT_TRUE(workers_->RegisterWorker(context.get(), request, &registered).ok());
  }
  auto lease = [&](const char* token) {
    auto context = WithToken(token);
    v1::LeaseTaskRequest request;
    request.set_worker_id(registered.worker_id());
    v1::LeaseTaskResponse leased;
    return workers_->LeaseTask(context.get(), request, &leased);
  };
  const grpc::Status stolen = lease(kOtherWorker);
  EXPECT_EQ(stolen.error_code(), grpc::StatusCode::PERMISSION_DENIED) << stolen.error_message();
  EXPECT_THAT(stolen.error_message(), HasSubstr("registered with another token"));
  {
    auto context = WithToken(kOtherWorker);
    v1::RenewLeaseRequest request;
    request.set_worker_id(registered.worker_id());
    request.set_task_id(std::string(32, 'a'));
    v1::RenewLeaseResponse renewed;
    EXPECT_EQ(workers_->RenewLease(context.get(), request, &renewed).error_code(),
              grpc::StatusCode::PERMISSION_DENIED);
  }
  {
    auto context = WithToken(kOtherWorker);
    v1::TaskUpdateAck ack;
    auto writer = workers_->ReportTask(context.get(), &ack);
    v1::TaskUpdate update;
    update.set_worker_id(registered.worker_id());
    update.set_task_id(std::string(32, 'a'));
    update.set_failed("spoofed");
    writer->Write(update);
    writer->WritesDone();
    EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::PERMISSION_DENIED);
  }
  EXPECT_TRUE(lease(kWorker).ok());
  EXPECT_TRUE(lease(kAdmin).ok());  // an admin may act for any worker
}

TEST_F(SecurityTest, WorkerLimitsAreEnforced) {
  ServerOptions options = Options();
  options.workers.max_artifact_bytes = 1000;
  options.workers.max_samples_bytes = 1000;
  Start(options);
  UploadScene(kAlice);
  ASSERT_TRUE(Submit(kAlice, nullptr).ok());
  v1::RegisterWorkerResponse registered;
  {
    auto context = WithToken(kWorker);
    v1::RegisterWorkerRequest request;
    request.set_name("w");
    ASSERT_TRUE(workers_->RegisterWorker(context.get(), request, &registered).ok());
  }
  v1::LeaseTaskResponse leased;
  {
    auto context = WithToken(kWorker);
    v1::LeaseTaskRequest request;
    request.set_worker_id(registered.worker_id());
    const grpc::Status s = workers_->LeaseTask(context.get(), request, &leased);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_TRUE(leased.has_task());
    ASSERT_EQ(leased.task().kind(), "gather");
  }
  auto report = [&](bool samples) {
    auto context = WithToken(kWorker);
    v1::TaskUpdateAck ack;
    auto writer = workers_->ReportTask(context.get(), &ack);
    v1::TaskUpdate update;
    update.set_worker_id(registered.worker_id());
    update.set_task_id(leased.task().id());
    v1::ArtifactChunk* chunk = samples ? update.mutable_samples() : update.mutable_artifact();
    if (!samples) update.set_artifact_name("atlases/kd.exr");
    chunk->set_total_size(1001);
    chunk->set_sha256(std::string(64, 'c'));
    chunk->set_data(std::string(10, 'x'));
    writer->Write(update);
    writer->WritesDone();
    return writer->Finish();
  };
  grpc::Status s = report(false);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("artifact.total_size: 1001 bytes"));
  s = report(true);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("samples.total_size: 1001 bytes"));
}

}  // namespace
}  // namespace mvbrdf::server
