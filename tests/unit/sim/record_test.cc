#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "clients/sim/record.h"
#include "clients/sim/scenario.h"
#include "common/dataset/dataset.h"
#include "tests/support/test_env.h"

namespace epmap::sim {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Every file under `root`, relative path -> bytes.
std::map<std::string, std::string> Snapshot(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = ReadAll(e.path());
  }
  return files;
}

ScenarioOptions Tiny(const std::string& name) {
  ScenarioOptions o;
  o.name = name;
  o.frames = 3;
  o.width = 160;
  o.height = 120;
  return o;
}

TEST(Record, HeadDatasetLoadsBackWithItsGroundTruth) {
  const auto dir = epmap::testing::FreshTempDir("sim-record");
  const auto s = MakeScenario(Tiny("head"));
  Record(*s, dir / "head", false);
  const auto d = dataset::Load(dir / "head");
  EXPECT_EQ(d.frames.size(), 3u);
  EXPECT_TRUE(d.rectified());
  EXPECT_NEAR(d.baseline_m(), 0.068, 1e-9);
  EXPECT_EQ(d.cam0.width, 160);
  EXPECT_EQ(d.joint_names, s->joint_names());
  EXPECT_EQ(d.joints.size(), 3u);
  ASSERT_TRUE(d.urdf.has_value());
  EXPECT_EQ(d.gt_camera_pose.size(), 3u);
  EXPECT_EQ(d.gt_disparity.size(), 3u);
  EXPECT_EQ(d.gt_unexpected.size(), 3u);
  // The recorded ground truth is the rendered one.
  const SimFrame f = s->Render(2);
  const cv::Mat gt = dataset::LoadGtDisparity(d, d.frames[2].stamp_ns);
  EXPECT_EQ(cv::norm(gt, f.gt_disparity, cv::NORM_INF), 0.0);
  EXPECT_EQ(d.frames[2].stamp_ns, f.stamp_ns);
  EXPECT_TRUE(fs::exists(dir / "head/mav0/gt_joints0/data.csv"));
  EXPECT_TRUE(fs::exists(dir / "head/mav0/gt_extrinsics0/data.csv"));
  EXPECT_TRUE(fs::exists(dir / "head/mav0/gt_kinematics.urdf"));
  // A non-empty folder is refused unless forced.
  EXPECT_THROW(Record(*s, dir / "head", false), std::runtime_error);
  EXPECT_NO_THROW(Record(*s, dir / "head", true));
  fs::remove_all(dir);
}

TEST(Record, SameSeedGivesByteIdenticalDatasets) {
  const auto dir = epmap::testing::FreshTempDir("sim-determinism");
  for (const std::string name : {"head", "vergence", "building", "eye-hand"}) {
    ScenarioOptions o = Tiny(name);
    if (name == "eye-hand") o.frames = o.width = o.height = 0;
    Record(*MakeScenario(o), dir / (name + "-a"), false);
    Record(*MakeScenario(o), dir / (name + "-b"), false);
    const auto a = Snapshot(dir / (name + "-a")), b = Snapshot(dir / (name + "-b"));
    ASSERT_GE(a.size(), 3u) << name;
    EXPECT_EQ(a.size(), b.size()) << name;
    for (const auto& [path, bytes] : a) {
      ASSERT_TRUE(b.count(path)) << name << ": " << path;
      EXPECT_TRUE(bytes == b.at(path)) << name << ": " << path << " differs";
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace epmap::sim
