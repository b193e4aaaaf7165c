// The real EuRoC excerpt (unrectified, distorted) replayed at its own 20 Hz: every frame is
// paired, rectified from the CameraInfo the replay derives from sensor.yaml, and processed,
// with nothing dropped; expected perception then recomputes little and flags almost nothing.

#include <gtest/gtest.h>

#include <cstdio>

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
  // Its memory, as an operator sees it: resident now, and a peak at least that.
  EXPECT_GT(status.resident_mb(), 10.0) << status.DebugString();
  EXPECT_GE(status.peak_resident_mb(), status.resident_mb()) << status.DebugString();
  // No URDF given: the status has no robot chain, and the mode is static.
  EXPECT_FALSE(status.has_robot()) << status.DebugString();
  EXPECT_EQ(status.mode(), "static") << status.DebugString();
  std::printf("epmapd after 40 EuRoC frames: resident %.1f MB, peak %.1f MB\n",
              status.resident_mb(), status.peak_resident_mb());

  // The served map is the rectified geometry of the VI-sensor (11 cm baseline).
  v1::DisparityMap map;
  grpc::ClientContext context;
  ASSERT_TRUE(epmapd.stub().GetDisparity(&context, {}, &map).ok());
  EXPECT_EQ(map.camera().width(), 752u);
  EXPECT_NEAR(map.camera().baseline_m(), 0.110, 0.002);
  EXPECT_GT(map.valid_share(), 0.5);

  // Expected perception on a real, almost still scene with a static-rig pose (issue 4): after
  // the first frame little is recomputed and almost nothing is flagged as moving on its own.
  EXPECT_LT(status.recomputed_share_median(), 0.20) << status.DebugString();
  EXPECT_LT(map.recomputed_share(), 0.20);
  v1::UnexpectedRegions regions;
  grpc::ClientContext regions_context;
  ASSERT_TRUE(epmapd.stub().GetUnexpectedRegions(&regions_context, {}, &regions).ok());
  EXPECT_LT(regions.flagged_share(), 0.02) << regions.DebugString();
  std::printf("EuRoC: recomputed share median %.3f (last %.3f), flagged %.4f\n",
              status.recomputed_share_median(), status.recomputed_share_last(),
              regions.flagged_share());
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap
