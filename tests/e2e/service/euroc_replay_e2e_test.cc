// The real EuRoC excerpt (unrectified, distorted) replayed at its own 20 Hz: every frame is
// paired, rectified from the CameraInfo the replay derives from sensor.yaml, and processed,
// with nothing dropped.

#include <gtest/gtest.h>

#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

TEST(EurocReplayE2E, AllFortyFramesProcessedAtTwentyHertz) {
  EPMAP_REQUIRE_SHARED_DATA("euroc-v101-excerpt");
  const auto work = testing::FreshTempDir("euroc");
  const uint32_t domain = testing::UniqueDomainId(101);
  testing::Epmapd epmapd(domain, {}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();

  const auto [code, out] =
      testing::RunToCompletion(testing::BinDir() / "epmap-replay",
                               {(testing::SharedDataDir() / "euroc-v101-excerpt").string(),
                                "--domain", std::to_string(domain)},
                               work / "replay.log", std::chrono::seconds(60));
  ASSERT_EQ(code, 0) << out;

  const auto status =
      epmapd.WaitStatus([](const v1::ServiceStatus& s) { return s.frames_processed() >= 40; },
                        std::chrono::seconds(30));
  EXPECT_EQ(status.frames_received(), 40u) << status.DebugString();
  EXPECT_EQ(status.frames_processed(), 40u) << status.DebugString();
  EXPECT_EQ(status.queue_dropped(), 0u) << status.DebugString();
  EXPECT_EQ(status.frames_rejected(), 0u) << status.DebugString();
  EXPECT_EQ(status.transport_lost_by_topic_size(), 0) << status.DebugString();
  EXPECT_EQ(status.last_stamp_ns(), 1403715275212143104LL);

  // The served map is the rectified geometry of the VI-sensor (11 cm baseline).
  v1::DisparityMap map;
  grpc::ClientContext context;
  ASSERT_TRUE(epmapd.stub().GetDisparity(&context, {}, &map).ok());
  EXPECT_EQ(map.camera().width(), 752u);
  EXPECT_NEAR(map.camera().baseline_m(), 0.110, 0.002);
  EXPECT_GT(map.valid_share(), 0.5);
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap
