// How the service reports an EP region: the centroid in the base frame comes from the camera's
// pose on the base (not from the frame the EP predicts in, which is the odometry frame on a
// mobile base), the eye-hand correction acts in the base frame, and a mobile base also gets the
// centroid in the odometry frame.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "services/mapping/pipeline/unexpected_events.h"

namespace epmap::mapping {
namespace {

ep::Region RegionAt(const Eigen::Vector3d& centroid_cam0) {
  ep::Region r;
  r.box = cv::Rect(10, 20, 30, 40);
  r.area_px = 900;
  r.mean_disparity_px = 12.5;
  r.has_centroid = true;
  r.centroid_cam0 = centroid_cam0;
  r.centroid_base = Eigen::Vector3d(99, 99, 99);  // the EP's own frame: not used
  return r;
}

Eigen::Isometry3d CameraOnBase() {  // 1 m up, looking along the base's x axis
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T.translation() = Eigen::Vector3d(0.1, 0, 1.0);
  return T;
}

TEST(DescribeRegion, OnAHeadTheCentroidIsInTheBaseFrameAndThereIsNoOdometryFrame) {
  const auto info = DescribeRegion(RegionAt({0.0, 0.0, 2.0}), 3, CameraOnBase(), std::nullopt);
  EXPECT_EQ(info.id, 3u);
  EXPECT_EQ(info.box, cv::Rect(10, 20, 30, 40));
  EXPECT_EQ(info.area_px, 900);
  EXPECT_TRUE(info.centroid_camera.isApprox(Eigen::Vector3d(0, 0, 2)));
  EXPECT_TRUE(info.centroid_base.isApprox(Eigen::Vector3d(2.1, 0, 1.0))) << info.centroid_base;
  EXPECT_FALSE(info.base_corrected);
  EXPECT_FALSE(info.centroid_odom.has_value());
}

TEST(DescribeRegion, OnAMobileBaseTheOdometryFrameComesAfterTheEyeHandCorrection) {
  Eigen::Isometry3d T_odom_base = Eigen::Isometry3d::Identity();  // at (5, 1), facing +y
  T_odom_base.linear() =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_odom_base.translation() = Eigen::Vector3d(5, 1, 0);
  const auto shift_up = [](const Eigen::Vector3d& x) -> Eigen::Vector3d {
    return x + Eigen::Vector3d(0, 0, 0.02);
  };
  const auto info =
      DescribeRegion(RegionAt({0.0, 0.0, 2.0}), 1, CameraOnBase(), T_odom_base, shift_up);
  EXPECT_TRUE(info.base_corrected);
  EXPECT_TRUE(info.centroid_base.isApprox(Eigen::Vector3d(2.1, 0, 1.02))) << info.centroid_base;
  ASSERT_TRUE(info.centroid_odom.has_value());
  // 2.1 m ahead of a base at (5, 1) facing +y: (5, 3.1), at the corrected height.
  EXPECT_TRUE(info.centroid_odom->isApprox(Eigen::Vector3d(5, 3.1, 1.02))) << *info.centroid_odom;
}

TEST(DescribeRegion, ARegionWithoutDepthIsNotCorrected) {
  ep::Region r = RegionAt({0, 0, 0});
  r.has_centroid = false;
  const auto info = DescribeRegion(r, 1, CameraOnBase(), std::nullopt,
                                   [](const Eigen::Vector3d& x) { return x; });
  EXPECT_FALSE(info.has_centroid);
  EXPECT_FALSE(info.base_corrected);
}

}  // namespace
}  // namespace epmap::mapping
