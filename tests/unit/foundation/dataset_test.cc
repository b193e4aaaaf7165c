#include <gtest/gtest.h>

#include "common/dataset/dataset.h"
#include "common/dataset/writer.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

TEST(Dataset, LoadsTheRealEurocExcerptAsItIs) {
  EPMAP_REQUIRE_SHARED_DATA("euroc-v101-excerpt");
  const auto d = dataset::Load(testing::SharedDataDir() / "euroc-v101-excerpt");
  EXPECT_EQ(d.kind, dataset::Dataset::Kind::kSequence);
  EXPECT_EQ(d.frames.size(), 40u);
  EXPECT_EQ(d.cam0.width, 752);
  EXPECT_EQ(d.cam0.distortion.size(), 4u);
  EXPECT_FALSE(d.rectified());
  EXPECT_NEAR(d.baseline_m(), 0.110, 0.005);  // EuRoC's VI-sensor has an 11 cm baseline
}

TEST(Dataset, LoadsAStereoPairFolder) {
  EPMAP_REQUIRE_SHARED_DATA("stereo-pairs/cones");
  const auto d = dataset::Load(testing::SharedDataDir() / "stereo-pairs/cones");
  EXPECT_EQ(d.kind, dataset::Dataset::Kind::kStereoPair);
  ASSERT_EQ(d.frames.size(), 1u);
  EXPECT_EQ(d.num_disparities, 64);
  const cv::Mat gt = dataset::LoadGtDisparity(d, d.frames[0].stamp_ns);
  ASSERT_FALSE(gt.empty());
  EXPECT_EQ(gt.cols, 450);
}

TEST(Dataset, WriterOutputLoadsBackAndRefusesNonEmptyFolder) {
  const auto dir = testing::FreshTempDir("writer");
  {
    dataset::Writer w(dir / "seq", false);
    dataset::CameraSensor cam;
    cam.width = 8;
    cam.height = 6;
    cam.fu = cam.fv = 10;
    cam.cu = 4;
    cam.cv = 3;
    cam.distortion = {0, 0, 0, 0};
    w.WriteCameraSensor(0, cam, "left");
    cam.T_BS(0, 3) = 0.1;
    w.WriteCameraSensor(1, cam, "right");
    const cv::Mat img(6, 8, CV_8UC1, cv::Scalar(7));
    w.AddStereoFrame(1000, img, img);
    w.AddStereoFrame(2000, img, img);
    w.SetJointNames({"a", "b"});
    w.AddJoints(1000, {0.1, 0.2});
    w.AddJoints(2000, {0.3, 0.4});
    w.WriteWalls({{0, 0, 1, 0}});
  }
  const auto d = dataset::Load(dir / "seq");
  EXPECT_EQ(d.frames.size(), 2u);
  EXPECT_TRUE(d.rectified());
  EXPECT_EQ(d.joint_names, (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(d.walls.size(), 1u);
  const auto mid = dataset::InterpolateJoints(d.joints, 1500);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR((*mid)[0], 0.2, 1e-9);
  EXPECT_THROW(dataset::Writer(dir / "seq", false), std::runtime_error);
  EXPECT_NO_THROW(dataset::Writer(dir / "seq", true));
  std::filesystem::remove_all(dir);
}

TEST(Dataset, MissingFolderIsAClearError) {
  try {
    dataset::Load("/nonexistent/epmap");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no such dataset"), std::string::npos);
  }
}

TEST(Dataset, PoseAtFindsTheSampleOfExactlyThatStamp) {
  std::vector<dataset::PoseSample> poses(3);
  for (int i = 0; i < 3; ++i) {
    poses[i].stamp_ns = 100 * (i + 1);
    poses[i].pose.translation() = Eigen::Vector3d(i, 0, 0);
  }
  const auto at = dataset::PoseAt(poses, 200);
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(at->translation().x(), 1.0);
  EXPECT_FALSE(dataset::PoseAt(poses, 250).has_value());  // between samples: none
  EXPECT_FALSE(dataset::PoseAt(poses, 400).has_value());
  EXPECT_FALSE(dataset::PoseAt({}, 100).has_value());
}

}  // namespace
}  // namespace epmap
