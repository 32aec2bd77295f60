#include "core/pipeline/stage_timer.h"

namespace mvbrdf::pipeline {

void StageTimer::Add(const std::string& name, double seconds) {
  for (v1::StageTime& s : steps_) {
    if (s.name() == name) {
      s.set_seconds(s.seconds() + seconds);
      s.set_calls(s.calls() + 1);
      return;
    }
  }
  v1::StageTime s;
  s.set_name(name);
  s.set_seconds(seconds);
  s.set_calls(1);
  steps_.push_back(s);
}

double StageTimer::Seconds(const std::string& name) const {
  for (const v1::StageTime& s : steps_) {
    if (s.name() == name) return s.seconds();
  }
  return 0.0;
}

void StageTimer::ToProto(google::protobuf::RepeatedPtrField<v1::StageTime>* out) const {
  for (const v1::StageTime& s : steps_) *out->Add() = s;
}

}  // namespace mvbrdf::pipeline
