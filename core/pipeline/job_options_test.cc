#include "core/pipeline/job_options.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace mvbrdf::pipeline {
namespace {

// Every request field ReconstructOptionsFor checks: out of range is
// INVALID_ARGUMENT naming the field and the value given (never a wrapped int).
TEST(JobOptionsTest, OutOfRangeOptionsNameTheField) {
  struct Case {
    std::function<void(v1::SubmitJobRequest*)> set;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_atlas_size(8); },
       "options.atlas_size: must be in [16, 16384], got 8"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_atlas_size(100000); },
       "options.atlas_size: must be in [16, 16384], got 100000"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_max_iterations(4294967295u); },
       "options.max_iterations: must be in [1, 100000], got 4294967295"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_sweep_frame_stride(4294967295u); },
       "options.sweep_frame_stride: must be in [1, 2147483647], got 4294967295"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_grow_iterations(3000000000u); },
       "options.grow_iterations: must be in [0, 16384], got 3000000000"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_max_cluster_samples(3); },
       "options.max_cluster_samples: must be >= 10, got 3"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_kd_prior_strength(-1.0); },
       "options.kd_prior_strength: must be finite and >= 0, got -1"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_kd_prior_strength(std::nan("")); },
       "options.kd_prior_strength: must be finite and >= 0, got nan"},
      {[](v1::SubmitJobRequest* r) { r->add_outputs(static_cast<v1::Output>(99)); }, "outputs[0]: unknown output 99"},
      {[](v1::SubmitJobRequest* r) { r->mutable_options()->set_brdf("cook"); },
       "options.brdf: expected phong, blinn-phong, ggx or auto, got \"cook\""},
  };
  for (const Case& c : cases) {
    v1::SubmitJobRequest request;
    c.set(&request);
    const auto options = ReconstructOptionsFor(request, 1);
    EXPECT_EQ(options.status().code(), absl::StatusCode::kInvalidArgument) << c.expected;
    EXPECT_NE(options.status().message().find(c.expected), std::string::npos)
        << "expected \"" << c.expected << "\" in: " << options.status();
  }
  v1::SubmitJobRequest largest;
  largest.mutable_options()->set_max_iterations(100000);
  largest.mutable_options()->set_grow_iterations(16384);
  largest.mutable_options()->set_sweep_frame_stride(2147483647u);
  EXPECT_TRUE(ReconstructOptionsFor(largest, 1).ok()) << ReconstructOptionsFor(largest, 1).status();
}

// The request's fields reach the options: outputs, the fixed configuration,
// the candidates and a fitting option (the rest of ReconstructOptionsFor's
// mapping is checked end to end by the CLI tests of each flag).
TEST(JobOptionsTest, TheRequestReachesTheOptions) {
  v1::SubmitJobRequest request;
  request.add_outputs(v1::OUTPUT_LIGHT_TABLE);
  request.set_configuration("NE,NW");
  request.add_configurations("NE,NW");
  request.add_configurations("C");
  request.mutable_options()->set_atlas_size(256);
  const auto options = ReconstructOptionsFor(request, 3);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_TRUE(options->request.light_table);
  EXPECT_FALSE(options->request.brdf_atlases);
  EXPECT_FALSE(options->request.correction);
  EXPECT_FALSE(options->request.camera_errors);
  EXPECT_EQ(options->request.configuration, "NE,NW");
  EXPECT_EQ(options->request.candidates, (std::vector<std::string>{"NE,NW", "C"}));
  EXPECT_EQ(options->atlas.size, 256);
  EXPECT_EQ(options->threads, 3);
  EXPECT_FALSE(options->brdf_auto);
  EXPECT_FALSE(options->GathersHalfVector());
  // --brdf auto (issue #15): every model is a candidate, so the half-vector
  // geometry is gathered.
  request.mutable_options()->set_brdf("auto");
  const auto automatic = ReconstructOptionsFor(request, 3);
  ASSERT_TRUE(automatic.ok()) << automatic.status();
  EXPECT_TRUE(automatic->brdf_auto);
  EXPECT_TRUE(automatic->GathersHalfVector());
}

}  // namespace
}  // namespace mvbrdf::pipeline
