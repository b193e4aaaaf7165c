#include <gtest/gtest.h>

#include "perception/localisation/pose_corrector.h"
#include "perception/mobile_mapping/joint_limits.h"
#include "perception/mobile_mapping/key_frame_selector.h"
#include "tests/support/planar_world.h"

namespace epmap {
namespace {

using localisation::MakePose;

TEST(KeyFrameSelector, MotionOrPanMakesAKeyFrame) {
  mobile_mapping::KeyFrameSelector s;
  const auto cam = testing::CameraOnBase(0);
  EXPECT_TRUE(s.Consider(MakePose(0, 0, 0), cam));  // the first frame
  EXPECT_FALSE(s.Consider(MakePose(0.1, 0, 0), cam));
  EXPECT_TRUE(s.Consider(MakePose(0.3, 0, 0), cam));  // 30 cm since the last key frame
  EXPECT_FALSE(s.Consider(MakePose(0.3, 0, 0.1), cam));
  EXPECT_TRUE(s.Consider(MakePose(0.3, 0, 0.2), cam));  // turned 0.2 rad
  EXPECT_FALSE(s.Consider(MakePose(0.3, 0, 0.2), testing::CameraOnBase(0.1)));
  EXPECT_TRUE(s.Consider(MakePose(0.3, 0, 0.2), testing::CameraOnBase(0.2)));  // panned
  mobile_mapping::KeyFrameSelectorParams bad;
  bad.min_translation_m = 0;
  EXPECT_THROW(mobile_mapping::KeyFrameSelector{bad}, std::invalid_argument);
}

TEST(JointLimits, ReadFromTheUrdf) {
  const auto limits = mobile_mapping::JointLimitsFromUrdf(testing::PanHeadUrdf(1.2), {"pan"});
  ASSERT_EQ(limits.size(), 1u);
  EXPECT_EQ(limits[0].name, "pan");
  EXPECT_DOUBLE_EQ(limits[0].lower, -1.2);
  EXPECT_DOUBLE_EQ(limits[0].upper, 1.2);
  EXPECT_THROW(mobile_mapping::JointLimitsFromUrdf(testing::PanHeadUrdf(), {"tilt"}),
               std::runtime_error);
  EXPECT_THROW(mobile_mapping::JointLimitsFromUrdf("<robot", {"pan"}), std::runtime_error);
}

}  // namespace
}  // namespace epmap
