#include "server/clients_api/job_proto.h"

#include <string>

#include <gtest/gtest.h>

#include "core/base/proto_json.h"
#include "server/store/test_dir.h"

namespace mvbrdf::clients_api {
namespace {

constexpr int64_t kT0 = 1'700'000'000'000;  // unix ms

TEST(JobProtoTest, TaskSecondsRunFromTheLeaseStartForFinishedTasks) {
  store::Task task;
  task.id = "t";
  task.kind = "gather";
  task.state = store::TaskState::kDone;
  task.started_ms = kT0;
  task.updated_ms = kT0 + 2500;
  task.samples_from_cache = true;
  v1::TaskInfo info = ToProto(task);
  EXPECT_DOUBLE_EQ(info.seconds(), 2.5);
  EXPECT_TRUE(info.samples_from_cache());

  task.state = store::TaskState::kFailed;
  EXPECT_DOUBLE_EQ(ToProto(task).seconds(), 2.5);
  task.state = store::TaskState::kLeased;  // still running
  EXPECT_DOUBLE_EQ(ToProto(task).seconds(), 0.0);
  task.state = store::TaskState::kDone;
  task.started_ms = 0;  // leased before the store recorded lease starts
  EXPECT_DOUBLE_EQ(ToProto(task).seconds(), 0.0);
  task.samples_from_cache = false;
  EXPECT_FALSE(ToProto(task).samples_from_cache());
}

TEST(JobProtoTest, SucceededJobCarriesItsResultJsonAsTheReport) {
  store::TestDir dir;
  auto artifacts = store::ArtifactStore::Open(dir.db(), dir.path() / "artifacts");
  ASSERT_TRUE(artifacts.ok()) << artifacts.status();
  v1::RunReport report;
  report.set_scene("scene.json");
  report.set_chosen_configuration("key+fill");
  report.set_frames(12);
  ASSERT_TRUE((*artifacts)->PutBytes("j1", kReportArtifact, MessageToJson(report), kT0).ok());
  ASSERT_TRUE((*artifacts)->PutBytes("j2", kReportArtifact, "{\"noSuchField\": 1}", kT0).ok());

  v1::Job job;
  job.set_id("j1");
  job.set_state(v1::RUNNING);
  AttachReport(**artifacts, job);
  EXPECT_FALSE(job.has_report());  // only once it succeeded

  job.set_state(v1::SUCCEEDED);
  AttachReport(**artifacts, job);
  ASSERT_TRUE(job.has_report());
  EXPECT_EQ(job.report().chosen_configuration(), "key+fill");
  EXPECT_EQ(job.report().frames(), 12u);

  v1::Job broken;
  broken.set_id("j2");
  broken.set_state(v1::SUCCEEDED);
  AttachReport(**artifacts, broken);
  EXPECT_FALSE(broken.has_report());
  v1::Job none;
  none.set_id("j3");
  none.set_state(v1::SUCCEEDED);
  AttachReport(**artifacts, none);
  EXPECT_FALSE(none.has_report());
}

}  // namespace
}  // namespace mvbrdf::clients_api
