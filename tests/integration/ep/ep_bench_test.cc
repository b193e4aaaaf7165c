// `epmap-bench ep` as a user runs it: on a small recorded head sequence (written here in the
// dataset layout, with a URDF, encoder readings and ground truth), on the real EuRoC excerpt
// (unrectified, no kinematics: a fixed rig), and on broken datasets (clear errors, no crash).

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "common/dataset/writer.h"
#include "common/process/child_process.h"
#include "perception/kinematics/urdf_chain.h"
#include "tests/support/head_urdf.h"
#include "tests/support/test_env.h"
#include "tests/unit/ep/synthetic_scene.h"

namespace epmap {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kJoints = {"neck_pitch", "neck_roll",    "neck_yaw",
                                          "eyes_tilt",  "left_eye_pan", "right_eye_pan"};

// The synthetic scene's rectified 30 Hz pair: cam0 at the body origin, cam1 a baseline along x.
void WriteRectifiedRig(const stereo::RectifiedGeometry& cam, dataset::Writer* w) {
  dataset::CameraSensor c;
  c.width = cam.width;
  c.height = cam.height;
  c.fu = c.fv = cam.fx;
  c.cu = cam.cx;
  c.cv = cam.cy;
  c.distortion = {0, 0, 0, 0};
  c.rate_hz = 30;
  w->WriteCameraSensor(0, c, "left");
  c.T_BS(0, 3) = cam.baseline_m;
  w->WriteCameraSensor(1, c, "right");
}

// A 14-frame head sequence: the test head's neck turning, the synthetic room, a square moving
// through it. Images are rendered from the chain's own poses (world = the first camera frame).
void WriteHeadSequence(const fs::path& root, const std::string& urdf,
                       const std::vector<std::string>& joint_names) {
  testing::SyntheticScene base;
  const auto& cam = base.camera();
  auto chain = kinematics::UrdfChain::FromString(testing::kHeadUrdf);
  chain.BindJointOrder(kJoints);
  const Eigen::Isometry3d T0 = chain.Cam0Pose({0, 0, 0, 0, 0, 0});
  dataset::Writer w(root, true);
  WriteRectifiedRig(cam, &w);
  w.SetJointNames(joint_names);
  w.WriteUrdf(urdf);
  for (int k = 0; k < 14; ++k) {
    const std::vector<double> q = {
        0.02 * std::sin(0.2 * k), 0.0, 0.08 * std::sin(0.15 * k), 0, 0, 0};
    testing::SyntheticScene scene = base;
    scene.SetMovingSquare(Eigen::Vector3d(-0.4 + 0.035 * k, -0.05, 1.2));
    cv::Mat l, r, d, m;
    scene.Render(T0.inverse() * chain.Cam0Pose(q), &l, &r, &d, &m);
    const int64_t stamp = 1'000'000'000LL + k * 33'333'333LL;
    w.AddStereoFrame(stamp, l, r);
    w.AddJoints(stamp, q);
    w.AddGtDisparity(stamp, d);
    w.AddGtUnexpected(stamp, m);
  }
}

std::pair<int, std::string> Bench(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {"ep"};
  all.insert(all.end(), args.begin(), args.end());
  return process::RunToCompletion(testing::BinDir() / "epmap-bench", all, log,
                                  std::chrono::minutes(4));
}

TEST(EpBench, RunsOnARecordedHeadWithKinematicsAndWritesTheMaps) {
  const fs::path dir = testing::FreshTempDir("ep-bench-head");
  WriteHeadSequence(dir / "seq", testing::kHeadUrdf, kJoints);
  const auto [code, out] =
      Bench({"--dataset", (dir / "seq").string(), "--json", "--num-disparities", "48", "--out",
             (dir / "out").string(), "--internal-model", "learned"},
            dir / "log.txt");
  ASSERT_EQ(code, 0) << out;
  for (const char* key :
       {"\"frames\":14", "\"pose_source\":\"urdf\"", "\"ep_ms_median\":", "\"full_ms_median\":",
        "\"recomputed_share_median\":", "\"bad2_ep\":0.", "\"bad2_full\":0.",
        "\"bad2_ep_first50\":", "\"bad2_ep_last50\":", "\"iou_median\":0.", "\"mean_E\":",
        "\"mean_A\":", "\"learned\":{", "\"reached_target\":true", "\"relative_to_urdf\":{"}) {
    EXPECT_NE(out.find(key), std::string::npos) << key << " missing in " << out;
  }
  int pfm = 0, png = 0;
  for (const auto& e : fs::directory_iterator(dir / "out")) {
    pfm += e.path().extension() == ".pfm";
    png += e.path().extension() == ".png";
  }
  EXPECT_EQ(pfm, 14);
  EXPECT_EQ(png, 14);
  EXPECT_TRUE(fs::exists(dir / "out" / "learned_model.yml"));
  fs::remove_all(dir);
}

TEST(EpBench, RefusesJointNamesTheUrdfLacksAndAUrdfWithoutCam0) {
  const fs::path dir = testing::FreshTempDir("ep-bench-bad");
  std::vector<std::string> renamed = kJoints;
  renamed[2] = "head_yaw";  // the URDF calls it neck_yaw
  WriteHeadSequence(dir / "names", testing::kHeadUrdf, renamed);
  auto [code, out] = Bench(
      {"--dataset", (dir / "names").string(), "--json", "--frames", "3", "--num-disparities", "48"},
      dir / "log1.txt");
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("neck_yaw"), std::string::npos) << out;
  std::string no_cam = testing::kHeadUrdf;
  for (size_t p; (p = no_cam.find("cam0_optical")) != std::string::npos;) {
    no_cam.replace(p, 12, "eye0_optical");
  }
  WriteHeadSequence(dir / "nocam", no_cam, kJoints);
  std::tie(code, out) = Bench(
      {"--dataset", (dir / "nocam").string(), "--json", "--frames", "3", "--num-disparities", "48"},
      dir / "log2.txt");
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("cam0_optical"), std::string::npos) << out;
  fs::remove_all(dir);
}

// A fixed rig on a mobile base (no kinematics, odometry0): the base slides sideways 3 cm a
// frame in front of the synthetic room, nothing moves on its own.
void WriteSlidingBaseSequence(const fs::path& root) {
  const testing::SyntheticScene scene;
  const auto& cam = scene.camera();
  dataset::Writer w(root, true);
  WriteRectifiedRig(cam, &w);  // cam0's T_BS = identity: on a base, the camera is the base
  for (int k = 0; k < 10; ++k) {
    const int64_t stamp = 1'000'000'000LL + k * 33'333'333LL;
    const double x = 0.03 * k;
    cv::Mat l, r, d, m;
    scene.Render(Eigen::Isometry3d(Eigen::Translation3d(x, 0, 0)), &l, &r, &d, &m);
    w.AddStereoFrame(stamp, l, r);
    w.AddOdometry({stamp, x, 0, 0});
    w.AddGtDisparity(stamp, d);
    w.AddGtUnexpected(stamp, cv::Mat::zeros(l.size(), CV_8U));
  }
}

TEST(EpBench, OnAMobileBaseTheCameraRidesOnTheOdometry) {
  const fs::path dir = testing::FreshTempDir("ep-bench-base");
  WriteSlidingBaseSequence(dir / "seq");
  const auto [code, out] = Bench(
      {"--dataset", (dir / "seq").string(), "--json", "--num-disparities", "48"}, dir / "log.txt");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"pose_source\":\"fixed\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"base_odometry\":true"), std::string::npos) << out;
  EXPECT_NE(out.find("\"pose_jumps\":0"), std::string::npos) << out;
  // Nothing moves on its own: a prediction that ignored the base's motion would be off by a few
  // pixels a frame and flag the room's texture.
  const std::string key = "\"flagged_area_not_visible_max\":";
  const size_t at = out.find(key);
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_LT(std::stod(out.substr(at + key.size())), 0.01) << out;
  fs::remove_all(dir);
}

TEST(EpBench, RunsOnTheRealEurocExcerptAsAFixedRig) {
  EPMAP_REQUIRE_SHARED_DATA("euroc-v101-excerpt");
  const fs::path dir = testing::FreshTempDir("ep-bench-euroc");
  const auto [code, out] =
      Bench({"--dataset", (testing::SharedDataDir() / "euroc-v101-excerpt").string(), "--json",
             "--frames", "6"},
            dir / "log.txt");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"pose_source\":\"fixed\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"rectified_here\":true"), std::string::npos) << out;
  EXPECT_NE(out.find("\"bad2_ep\":null"), std::string::npos) << out;  // no ground truth
  fs::remove_all(dir);
}

}  // namespace
}  // namespace epmap
