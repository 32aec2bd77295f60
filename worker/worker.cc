#include "worker/worker.h"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <system_error>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "core/bundle/sha256.h"
#include "worker/bundle_cache.h"
#include "worker/task_runner.h"
#include "worker/worker_fault.h"

namespace mvbrdf::worker {
namespace {

namespace fs = std::filesystem;
using SteadyClock = std::chrono::steady_clock;

constexpr size_t kChunkBytes = size_t{1} << 20;

// A failure that another attempt (on any worker) would repeat: bad input or a
// limit. Transient ones (unavailable, data loss in transit, internal) retry.
bool IsPermanent(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kResourceExhausted:
    case absl::StatusCode::kOutOfRange:
      return true;
    default:
      return false;
  }
}

int64_t SteadyMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(SteadyClock::now().time_since_epoch()).count();
}

// Whether this worker can write its cache directory: a 256 KiB file written,
// synced and removed (a full or read-only disk fails it).
absl::Status ProbeCacheDir(const fs::path& dir) {
  const fs::path probe = dir / absl::StrCat(".probe-", getpid());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return ErrnoStatus(errno, "cannot create a file in the cache directory", probe.string());
  absl::Status written = WriteAllToFd(fd, std::string(256 << 10, '\0'), probe.string());
  if (written.ok() && ::fsync(fd) != 0) written = ErrnoStatus(errno, "fsync", probe.string());
  ::close(fd);
  ::unlink(probe.c_str());
  return written;
}

// Whether a failed task failed on this worker's own environment rather than
// on the job: marked so where the cause is known (out of memory, the bundle
// cache's disk), or a system error naming a file of the cache directory, or
// any failure while the cache directory fails the probe (a full disk also
// breaks writes whose errors do not say so).
bool IsOwnFault(const absl::Status& status, const fs::path& cache_dir, std::string* why) {
  if (IsMarkedWorkerFault(status)) return true;
  // A file system error (ErrnoStatus's codes) on a file of this worker's; a
  // limit or a parse error naming a file of the unpacked bundle is the job's.
  const bool full = absl::IsResourceExhausted(status) && (absl::StrContains(status.message(), "No space left") ||
                                                          absl::StrContains(status.message(), "quota"));
  const bool system = full || absl::IsPermissionDenied(status) || absl::IsUnavailable(status);
  if (system && absl::StrContains(status.message(), cache_dir.string())) return true;
  const absl::Status probe = ProbeCacheDir(cache_dir);
  if (probe.ok()) return false;
  *why = std::string(probe.message());
  return true;
}

// Tasks that render or resample need the EGL context; the others are CPU only.
bool UsesGl(const std::string& kind) { return kind != "sweep" && kind != "choose"; }

absl::Status FromGrpc(const grpc::Status& status, absl::string_view what) {
  if (status.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                      absl::StrCat(what, ": ", status.error_message()));
}

// Reads a server stream of ArtifactChunks into `sink`; checks offsets and the
// total size (callers check the SHA-256 of what they keep).
template <typename Sink>
absl::Status ReadChunks(grpc::ClientReader<v1::ArtifactChunk>& reader, absl::string_view what, Sink sink) {
  v1::ArtifactChunk chunk;
  uint64_t received = 0, total = 0;
  std::string sha256;
  bool first = true;
  while (reader.Read(&chunk)) {
    if (first) {
      total = chunk.total_size();
      sha256 = chunk.sha256();
      first = false;
    }
    if (chunk.offset() != received) {
      return absl::DataLossError(absl::StrCat(what, ": chunk at offset ", chunk.offset(), ", expected ", received));
    }
    MVBRDF_RETURN_IF_ERROR(sink(chunk.data()));
    received += chunk.data().size();
  }
  MVBRDF_RETURN_IF_ERROR(FromGrpc(reader.Finish(), what));
  if (received != total) {
    return absl::DataLossError(absl::StrCat(what, ": received ", received, " of ", total, " bytes"));
  }
  return absl::OkStatus();
}

// Sends `bytes` (or the file at `path`) as chunks of `field` of TaskUpdate.
class UpdateWriter {
 public:
  UpdateWriter(grpc::ClientWriter<v1::TaskUpdate>& writer, const std::string& worker_id, const std::string& task_id)
      : writer_(writer), worker_id_(worker_id), task_id_(task_id) {}

  bool Write(v1::TaskUpdate update) {
    update.set_worker_id(worker_id_);
    update.set_task_id(task_id_);
    return writer_.Write(update);
  }

  // Chunks of `bytes` into the samples field (samples = true) or an artifact.
  // `sha256`: of `bytes` when known (computed otherwise).
  bool WriteBytes(absl::string_view bytes, bool samples, const std::string& name, std::string sha256 = "") {
    if (sha256.empty()) sha256 = bundle::Sha256Bytes(bytes);
    size_t offset = 0;
    do {
      v1::TaskUpdate update;
      v1::ArtifactChunk* chunk = samples ? update.mutable_samples() : update.mutable_artifact();
      if (!samples) update.set_artifact_name(name);
      const size_t n = std::min(kChunkBytes, bytes.size() - offset);
      chunk->set_offset(offset);
      chunk->set_data(bytes.data() + offset, n);
      if (offset == 0) {
        chunk->set_total_size(bytes.size());
        chunk->set_sha256(sha256);
      }
      if (!Write(std::move(update))) return false;
      offset += n;
    } while (offset < bytes.size());
    return true;
  }

 private:
  grpc::ClientWriter<v1::TaskUpdate>& writer_;
  const std::string& worker_id_;
  const std::string& task_id_;
};


// Renews a lease every `period` until stopped; `lost` is set when the server
// refuses (the lease went to another worker, or the job ended).
class LeaseRenewer {
 public:
  LeaseRenewer(v1::Workers::Stub& stub, std::string worker_id, std::string task_id, std::chrono::milliseconds period)
      : thread_([this, &stub, worker_id, task_id, period] {
          std::unique_lock<std::mutex> lock(mu_);
          while (!cv_.wait_for(lock, period, [this] { return done_; })) {
            lock.unlock();
            grpc::ClientContext context;
            context.set_deadline(std::chrono::system_clock::now() + period);
            v1::RenewLeaseRequest request;
            request.set_worker_id(worker_id);
            request.set_task_id(task_id);
            v1::RenewLeaseResponse response;
            const grpc::Status status = stub.RenewLease(&context, request, &response);
            // Unreachable for a moment: try again next period; refused: lost.
            if (!status.ok() && status.error_code() != grpc::StatusCode::UNAVAILABLE &&
                status.error_code() != grpc::StatusCode::DEADLINE_EXCEEDED) {
              lost_ = true;
            }
            lock.lock();
          }
        }) {}
  ~LeaseRenewer() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  bool lost() const { return lost_; }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool done_ = false;
  std::atomic<bool> lost_{false};
  std::thread thread_;  // last: starts after the members above exist
};

// Turns the pipeline's (stage, done, total) calls into Progress updates with
// an ETA, at most every 250 ms per stage.
class ProgressReporter {
 public:
  explicit ProgressReporter(std::function<void(const v1::Progress&)> send) : send_(std::move(send)) {}
  void Update(const std::string& stage, int done, int total) {
    const auto now = SteadyClock::now();
    if (stage != stage_) {
      stage_ = stage;
      start_ = now;
      last_ = SteadyClock::time_point();
    }
    if (done < total && now - last_ < std::chrono::milliseconds(250)) return;
    last_ = now;
    v1::Progress p;
    p.set_stage(stage);
    p.set_fraction(total > 0 ? static_cast<double>(done) / total : 1.0);
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    p.set_eta_seconds(done > 0 ? elapsed * (total - done) / done : -1.0);
    send_(p);
  }

 private:
  std::function<void(const v1::Progress&)> send_;
  std::string stage_;
  SteadyClock::time_point start_, last_;
};

}  // namespace

std::string Worker::id() const {
  std::lock_guard<std::mutex> lock(mu_);
  return id_;
}

void Worker::Log(const std::string& line) const {
  if (options_.log) options_.log(line);
}

void Worker::Stop() {
  stop_ = true;
  std::lock_guard<std::mutex> lock(mu_);
  if (poll_ != nullptr) poll_->TryCancel();
}

void Worker::NoteTaskOutcome(bool own_fault) {
  if (!own_fault) {
    own_faults_ = 0;
    return;
  }
  // 1 s, 2 s, ... 30 s: a healthy worker takes the queue meanwhile.
  const int n = ++own_faults_;
  const int64_t backoff_ms = std::min<int64_t>(30000, int64_t{1000} << std::min(n - 1, 5));
  backoff_until_ms_ = SteadyMs() + backoff_ms;
  Log(absl::StrCat("not leasing for ", backoff_ms / 1000, " s after a failure of this worker's own environment"));
}

void Worker::WaitUntilHealthy() {
  if (own_faults_ == 0) return;
  while (!stop_ && SteadyMs() < backoff_until_ms_) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::string last;
  while (!stop_) {
    const absl::Status probe = ProbeCacheDir(options_.cache_dir);
    if (probe.ok()) break;
    if (probe.message() != last) {
      last = std::string(probe.message());
      Log(absl::StrCat("not leasing while the cache directory is unusable: ", last));
    }
    for (int i = 0; i < 20 && !stop_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!last.empty() && !stop_) Log("the cache directory works again; leasing");
}

absl::Status Worker::Register(v1::Workers::Stub& stub, const gl::EglContext& context) {
  v1::RegisterWorkerRequest request;
  request.set_name(options_.name);
  request.set_gl_renderer(context.Describe());
  request.set_threads(static_cast<uint32_t>(options_.threads));
  for (int attempt = 0;; ++attempt) {
    grpc::ClientContext rpc;
    rpc.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::RegisterWorkerResponse response;
    const grpc::Status status = stub.RegisterWorker(&rpc, request, &response);
    if (status.ok()) {
      std::lock_guard<std::mutex> lock(mu_);
      id_ = response.worker_id();
      lease_seconds_ = std::max<int>(1, static_cast<int>(response.lease_seconds()));
      break;
    }
    if (status.error_code() != grpc::StatusCode::UNAVAILABLE || stop_) return FromGrpc(status, "RegisterWorker");
    if (attempt % 10 == 0) Log(absl::StrCat("server unavailable (", status.error_message(), "); retrying"));
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  Log(absl::StrCat("registered as ", id(), " (", context.Describe(), ")"));
  return absl::OkStatus();
}

absl::Status Worker::Run() {
  if (options_.channel == nullptr) return absl::InvalidArgumentError("worker: no channel to the server");
  MVBRDF_ASSIGN_OR_RETURN(std::unique_ptr<gl::EglContext> context, gl::EglContext::Create(options_.egl));
  std::error_code ec;
  fs::create_directories(options_.cache_dir, ec);
  if (ec) return absl::FailedPreconditionError(absl::StrCat(options_.cache_dir.string(), ": cannot create: ", ec.message()));
  std::unique_ptr<v1::Workers::Stub> stub = v1::Workers::NewStub(options_.channel);
  MVBRDF_RETURN_IF_ERROR(Register(*stub, *context));
  // A cache directory that cannot be written: registered (the server lists
  // the worker) but not leasing until it can (WaitUntilHealthy).
  if (!ProbeCacheDir(options_.cache_dir).ok()) own_faults_ = 1;
  BundleCache cache(options_.cache_dir / "bundles", [this, &stub](const std::string& sha256, const fs::path& dest) {
    grpc::ClientContext rpc;
    v1::FetchBundleRequest request;
    request.set_worker_id(id());
    request.set_sha256(sha256);
    std::unique_ptr<grpc::ClientReader<v1::ArtifactChunk>> reader = stub->FetchBundle(&rpc, request);
    std::ofstream out(dest, std::ios::binary | std::ios::trunc);
    // This worker's disk: not the job's fault.
    if (!out) return WorkerFault(absl::UnavailableError(absl::StrCat(dest.string(), ": cannot write")));
    absl::Status read =
        ReadChunks(*reader, absl::StrCat("FetchBundle ", sha256), [&out, &dest](const std::string& data) {
          out.write(data.data(), static_cast<std::streamsize>(data.size()));
          return out ? absl::OkStatus()
                     : WorkerFault(absl::UnavailableError(
                           absl::StrCat(dest.string(), ": cannot write the bundle (disk full?)")));
        });
    ++bundle_downloads_;
    return read;
  }, options_.server_unpacked_bundles);

  // GL tasks (gather, reflectance) run here, on the context's thread, one at
  // a time; CPU-only tasks (sweep, choose) run on their own threads, up to
  // `threads` at once, so one worker sweeps configurations in parallel.
  const int max_cpu_tasks = std::max(1, options_.threads);
  std::mutex slots_mu;
  std::condition_variable slots_cv;
  int running_cpu_tasks = 0;  // guarded by slots_mu
  struct CpuTask {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  std::vector<CpuTask> cpu_tasks;
  const auto join_finished = [&cpu_tasks](bool all) {
    for (auto it = cpu_tasks.begin(); it != cpu_tasks.end();) {
      if (all || *it->done) {
        it->thread.join();
        it = cpu_tasks.erase(it);
      } else {
        ++it;
      }
    }
  };
  const auto run_one = [this, &stub, &cache](const v1::Task& task, gl::EglContext& gl) -> void {
    Log(absl::StrCat("leased ", task.kind(), task.key().empty() ? "" : absl::StrCat("[", task.key(), "]"),
                     " of job ", task.job_id()));
    const auto start = SteadyClock::now();
    const absl::Status ran = RunLeased(*stub, task, gl, cache);
    const double seconds = std::chrono::duration<double>(SteadyClock::now() - start).count();
    if (ran.ok()) {
      Log(absl::StrCat(task.kind(), " done in ", seconds, " s"));
    } else {
      Log(absl::StrCat(task.kind(), " ended: ", ran.message()));
    }
  };

  while (!stop_) {
    join_finished(false);
    {
      std::unique_lock<std::mutex> lock(slots_mu);
      slots_cv.wait(lock, [&] { return running_cpu_tasks < max_cpu_tasks || stop_; });
      if (options_.max_tasks > 0 && tasks_run_ + running_cpu_tasks >= options_.max_tasks) break;
    }
    WaitUntilHealthy();
    if (stop_) break;
    grpc::ClientContext rpc;
    rpc.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(options_.wait_seconds + 30));
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stop_) break;
      poll_ = &rpc;
    }
    v1::LeaseTaskRequest request;
    request.set_worker_id(id());
    request.set_wait_seconds(static_cast<uint32_t>(options_.wait_seconds));
    v1::LeaseTaskResponse response;
    const grpc::Status status = stub->LeaseTask(&rpc, request, &response);
    {
      std::lock_guard<std::mutex> lock(mu_);
      poll_ = nullptr;
    }
    if (stop_) {
      // A task leased as we stopped goes back when its lease expires.
      break;
    }
    if (!status.ok()) {
      if (status.error_code() == grpc::StatusCode::NOT_FOUND ||
          status.error_code() == grpc::StatusCode::FAILED_PRECONDITION) {
        // A restarted server forgot us: register again.
        if (absl::Status registered = Register(*stub, *context); !registered.ok()) {
          join_finished(true);  // CPU tasks still hold references into this frame
          return registered;
        }
        continue;
      }
      if (status.error_code() != grpc::StatusCode::UNAVAILABLE &&
          status.error_code() != grpc::StatusCode::DEADLINE_EXCEEDED &&
          status.error_code() != grpc::StatusCode::CANCELLED) {
        join_finished(true);
        return FromGrpc(status, "LeaseTask");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      continue;
    }
    if (!response.has_task()) continue;
    const v1::Task& task = response.task();
    if (!UsesGl(task.kind())) {
      {
        std::lock_guard<std::mutex> lock(slots_mu);
        ++running_cpu_tasks;
      }
      auto done = std::make_shared<std::atomic<bool>>(false);
      cpu_tasks.push_back({std::thread([&, task, done] {
                             run_one(task, *context);
                             {
                               // Both counts at once, so max_tasks never sees the task twice.
                               std::lock_guard<std::mutex> lock(slots_mu);
                               --running_cpu_tasks;
                               ++tasks_run_;
                             }
                             *done = true;
                             slots_cv.notify_all();
                           }),
                           done});
      continue;
    }
    run_one(task, *context);
    ++tasks_run_;
  }
  join_finished(true);
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<const samples::SampleSet>> Worker::FetchSamples(v1::Workers::Stub& stub,
                                                                               const v1::Task& task,
                                                                               const v1::GatherResult& gathered) {
  // One download at a time: concurrent sweeps of a job wait for the first
  // and share its Samples.
  std::lock_guard<std::mutex> lock(samples_mu_);
  if (samples_ != nullptr && !gathered.samples_sha256().empty() && gathered.samples_sha256() == samples_sha256_) {
    return samples_;
  }
  grpc::ClientContext rpc;
  v1::FetchSamplesRequest request;
  request.set_worker_id(id());
  request.set_task_id(task.id());
  std::unique_ptr<grpc::ClientReader<v1::ArtifactChunk>> reader = stub.FetchSamples(&rpc, request);
  std::string bytes;
  MVBRDF_RETURN_IF_ERROR(ReadChunks(*reader, "FetchSamples", [&bytes](const std::string& data) {
    bytes += data;
    return absl::OkStatus();
  }));
  ++samples_downloads_;
  const std::string sha256 = bundle::Sha256Bytes(bytes);
  if (!gathered.samples_sha256().empty() && sha256 != gathered.samples_sha256()) {
    return absl::DataLossError(absl::StrCat("FetchSamples: SHA-256 ", sha256, ", the gather task reported ",
                                            gathered.samples_sha256()));
  }
  MVBRDF_ASSIGN_OR_RETURN(samples::SampleSet set, samples::DecodeSampleSet(bytes));
  samples_ = std::make_shared<const samples::SampleSet>(std::move(set));
  samples_sha256_ = sha256;
  return samples_;
}

absl::Status Worker::RunLeased(v1::Workers::Stub& stub, const v1::Task& task, gl::EglContext& context,
                               BundleCache& cache) {
  const std::string worker_id = id();
  LeaseRenewer renewer(stub, worker_id, task.id(), std::chrono::milliseconds(lease_seconds_.load() * 1000 / 3));
  grpc::ClientContext rpc;
  v1::TaskUpdateAck ack;
  std::unique_ptr<grpc::ClientWriter<v1::TaskUpdate>> stream = stub.ReportTask(&rpc, &ack);
  UpdateWriter writer(*stream, worker_id, task.id());
  bool stream_ok = true;
  ProgressReporter progress([&](const v1::Progress& p) {
    v1::TaskUpdate update;
    *update.mutable_progress() = p;
    stream_ok = stream_ok && writer.Write(std::move(update));
  });

  const fs::path scratch = options_.cache_dir / "tasks" / task.id();
  std::error_code ec;
  fs::remove_all(scratch, ec);
  fs::create_directories(scratch, ec);
  TaskEnvironment env;
  env.gl = &context;
  // CPU-only tasks run up to `threads` at once: one thread each.
  env.threads = UsesGl(task.kind()) ? options_.threads : 1;
  env.scratch_dir = scratch;
  env.progress = [&progress](const std::string& stage, int done, int total) { progress.Update(stage, done, total); };
  env.cancelled = [&renewer, &stream_ok] { return renewer.lost() || !stream_ok; };
  env.samples = [this, &stub, &task](const v1::GatherResult& gathered) { return FetchSamples(stub, task, gathered); };
  env.gather_texel_statistics = options_.gather_texel_statistics;
  env.report_html = options_.report_html;
  {
    // Pass 1's texel statistics from this worker's gather of the same job.
    std::lock_guard<std::mutex> lock(texels_mu_);
    if (task.kind() == "reflectance" && texels_job_ == task.job_id()) env.texel_statistics = std::move(texels_);
    if (UsesGl(task.kind())) {
      texels_.reset();
      texels_job_.clear();
    }
  }

  if (UsesGl(task.kind())) {
    // A new resampling pass: the last job's triangle Samples are not needed
    // by this worker any more (running sweeps hold their own reference).
    std::lock_guard<std::mutex> lock(samples_mu_);
    samples_.reset();
    samples_sha256_.clear();
  }
  const auto start = SteadyClock::now();
  absl::StatusOr<TaskOutput> output = [&]() -> absl::StatusOr<TaskOutput> {
    std::shared_ptr<const scene::Sequence> sequence;
    {
      std::lock_guard<std::mutex> lock(cache_mu_);
      MVBRDF_ASSIGN_OR_RETURN(sequence, cache.Sequence(task.bundle_sha256(), task.request().scene_path()));
    }
    return RunTask(task, *sequence, std::move(env));
  }();
  const double seconds = std::chrono::duration<double>(SteadyClock::now() - start).count();

  absl::Status outcome = absl::OkStatus();
  bool own_fault = false;
  if (renewer.lost()) {
    outcome = absl::AbortedError("the lease was lost (the task went to another worker or its job ended)");
  } else if (!output.ok()) {
    std::string probe;
    own_fault = IsOwnFault(output.status(), options_.cache_dir, &probe);
    v1::TaskUpdate update;
    update.set_failed(probe.empty()
                          ? std::string(output.status().message())
                          : absl::StrCat(output.status().message(), " (this worker's cache directory: ", probe, ")"));
    update.set_worker_fault(own_fault);
    update.set_permanent(!own_fault && IsPermanent(output.status()));
    writer.Write(std::move(update));
    if (own_fault) ++own_faults_reported_;
    outcome = output.status();
  } else {
    bool ok = stream_ok;
    if (ok && !output->samples.empty()) {
      v1::GatherResult gathered;
      gathered.ParseFromString(output->result);
      const std::string sha256 = gathered.samples_sha256();
      ok = writer.WriteBytes(output->samples, /*samples=*/true, "", sha256);
      std::string().swap(output->samples);  // sent: release the encoding
      // Keep the decoded Samples for this worker's sweeps of the job.
      std::lock_guard<std::mutex> lock(samples_mu_);
      samples_ = output->sample_set;
      samples_sha256_ = sha256;
    }
    if (output->texel_statistics != nullptr) {
      std::lock_guard<std::mutex> lock(texels_mu_);
      texels_ = std::move(output->texel_statistics);
      texels_job_ = task.job_id();
    }
    for (const auto& [name, path] : output->artifacts) {
      if (!ok) break;
      absl::StatusOr<std::string> bytes = ReadFileToString(path);
      if (!bytes.ok()) {
        outcome = bytes.status();
        break;
      }
      ok = writer.WriteBytes(*bytes, /*samples=*/false, name);
    }
    if (ok && outcome.ok()) {
      v1::TaskUpdate finished;
      v1::StageFinished* stage = finished.mutable_stage_finished();
      stage->set_stage(task.kind());
      stage->set_seconds(seconds);
      for (const auto& [key, value] : output->metrics) (*stage->mutable_metrics())[key] = value;
      if (output->samples_from_cache) (*stage->mutable_metrics())["samples_from_cache"] = 1.0;
      ok = writer.Write(std::move(finished));
      v1::TaskUpdate result;
      result.set_result(output->result);
      ok = ok && writer.Write(std::move(result));
    }
    if (!outcome.ok()) {
      // An output this worker wrote cannot be read back: its disk.
      own_fault = true;
      ++own_faults_reported_;
      v1::TaskUpdate update;
      update.set_failed(std::string(outcome.message()));
      update.set_worker_fault(true);
      writer.Write(std::move(update));
    }
  }
  stream->WritesDone();
  const grpc::Status finished = stream->Finish();
  fs::remove_all(scratch, ec);
  // Too little memory for this task's atlas says nothing about the next
  // task's: no back-off (the server retries the task elsewhere, a bounded
  // number of times). A disk or EGL failure stops leasing for a while.
  const bool out_of_memory = absl::IsResourceExhausted(outcome) && absl::StrContains(outcome.message(), "needs about");
  if (!renewer.lost()) NoteTaskOutcome(own_fault && !out_of_memory);
  if (!outcome.ok()) return outcome;
  if (!finished.ok()) return FromGrpc(finished, "ReportTask");
  if (!ack.accepted()) return absl::AbortedError("the server did not accept the result (the lease was lost)");
  return absl::OkStatus();
}

}  // namespace mvbrdf::worker
