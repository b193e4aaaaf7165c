// The Python planner example (grpcio) against a real epmapd fed by epmap-replay over DDS.

#include <gtest/gtest.h>

#include "common/dataset/dataset.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

TEST(PythonClientE2E, PlannerExampleReadsDepthAhead) {
  if (!std::filesystem::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  EPMAP_REQUIRE_SHARED_DATA("stereo-pairs/cones");
  const auto work = testing::FreshTempDir("python");
  const uint32_t domain = testing::UniqueDomainId(303);
  testing::Epmapd epmapd(domain, {}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  const auto [replay_code, replay_out] =
      testing::RunToCompletion(testing::BinDir() / "epmap-replay",
                               {(testing::SharedDataDir() / "stereo-pairs/cones").string(),
                                "--domain", std::to_string(domain)},
                               work / "replay.log", std::chrono::seconds(60));
  ASSERT_EQ(replay_code, 0) << replay_out;

  const auto script = testing::SourceDir() / "clients/python/epmap_planner.py";
  const auto stubs = testing::BinDir().parent_path() / "python";
  const auto [code, out] = testing::RunToCompletion(
      "/usr/bin/python3",
      {script.string(), "--server", epmapd.address(), "--stubs", stubs.string()},
      work / "python.log", std::chrono::seconds(60));
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"frames_processed\": 1"), std::string::npos) << out;
  EXPECT_NE(out.find("\"width\": 450"), std::string::npos) << out;
  EXPECT_NE(out.find("\"depth_ahead_median_m\": "), std::string::npos) << out;
  EXPECT_EQ(out.find("\"depth_ahead_median_m\": null"), std::string::npos) << out;
  // A single still pair: expected perception has compared nothing, so nothing moved.
  EXPECT_NE(out.find("\"moving_on_its_own\": []"), std::string::npos) << out;
  std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace epmap
