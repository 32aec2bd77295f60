// Accumulates wall time per named step of a stage, for reports and benchmarks.
#ifndef MVBRDF_CORE_PIPELINE_STAGE_TIMER_H_
#define MVBRDF_CORE_PIPELINE_STAGE_TIMER_H_

#include <chrono>
#include <string>
#include <vector>

#include "mvbrdf/v1/resample_report.pb.h"

namespace mvbrdf::pipeline {

class StageTimer {
 public:
  // Times the rest of the enclosing scope under `name`.
  class Scope {
   public:
    Scope(StageTimer* timer, const char* name)
        : timer_(timer), name_(name), start_(std::chrono::steady_clock::now()) {}
    ~Scope() { timer_->Add(name_, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count()); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimer* timer_;
    const char* name_;
    std::chrono::steady_clock::time_point start_;
  };

  void Add(const std::string& name, double seconds);
  double Seconds(const std::string& name) const;
  // In first-use order.
  void ToProto(google::protobuf::RepeatedPtrField<v1::StageTime>* out) const;

 private:
  std::vector<v1::StageTime> steps_;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_STAGE_TIMER_H_
