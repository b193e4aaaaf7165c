#include <gtest/gtest.h>

#include <cmath>

#include "services/mapping/ingest/bounded_queue.h"
#include "services/mapping/ingest/sensor_state.h"
#include "services/mapping/ingest/stereo_synchronizer.h"

namespace epmap {
namespace {

using mapping::CounterSet;
using mapping::StereoSynchronizer;
using Side = StereoSynchronizer::Side;

cv::Mat Img(int w = 8, int h = 6) {
  return cv::Mat(h, w, CV_8UC1, cv::Scalar(1));
}

TEST(StereoSynchronizer, PairsByStampInEitherArrivalOrder) {
  CounterSet rejected;
  StereoSynchronizer sync(1'000'000, 500'000'000, rejected);
  EXPECT_FALSE(sync.Add(Side::kLeft, 100'000'000, Img(), "left_optical"));
  auto pair = sync.Add(Side::kRight, 100'000'500, Img(), "right_optical");  // within 1 ms
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->stamp_ns, 100'000'000);     // the left stamp names the frame
  EXPECT_EQ(pair->frame_id, "left_optical");  // and the left camera's frame
  EXPECT_FALSE(sync.Add(Side::kRight, 200'000'000, Img(), "right_optical"));
  pair = sync.Add(Side::kLeft, 200'000'000, Img(), "left_optical");
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->frame_id, "left_optical");
  EXPECT_EQ(rejected.Total(), 0u);
}

TEST(StereoSynchronizer, RefusesBackwardsStampsMismatchedSizesAndCountsOrphans) {
  CounterSet rejected;
  StereoSynchronizer sync(1'000'000, 50'000'000, rejected);
  ASSERT_FALSE(sync.Add(Side::kLeft, 100'000'000, Img()));
  ASSERT_TRUE(sync.Add(Side::kRight, 100'000'000, Img()));
  EXPECT_FALSE(sync.Add(Side::kLeft, 90'000'000, Img()));
  EXPECT_EQ(rejected.Get("left_image:stamp_not_increasing"), 1u);
  ASSERT_FALSE(sync.Add(Side::kLeft, 110'000'000, Img()));
  EXPECT_FALSE(sync.Add(Side::kRight, 110'000'000, Img(16, 12)));
  EXPECT_EQ(rejected.Get("pair:size_mismatch"), 1u);
  // A left image whose right never comes is dropped as unpaired once it is too old.
  ASSERT_FALSE(sync.Add(Side::kLeft, 120'000'000, Img()));
  ASSERT_FALSE(sync.Add(Side::kLeft, 300'000'000, Img()));
  EXPECT_EQ(rejected.Get("left_image:unpaired"), 1u);
}

TEST(BoundedQueue, DropsTheOldestWhenFull) {
  mapping::BoundedQueue<int> q(2);
  EXPECT_EQ(q.Push(1), 0u);
  EXPECT_EQ(q.Push(2), 0u);
  EXPECT_EQ(q.Push(3), 1u);
  EXPECT_EQ(q.Pop(std::chrono::milliseconds(1)), 2);
  EXPECT_EQ(q.Pop(std::chrono::milliseconds(1)), 3);
  EXPECT_FALSE(q.Pop(std::chrono::milliseconds(1)));
  q.Close();
  EXPECT_EQ(q.Push(4), 0u);
  EXPECT_FALSE(q.Pop(std::chrono::milliseconds(1)));
}

TEST(SensorState, InterpolatesJointsByNameAtTheImageStamp) {
  CounterSet rejected;
  mapping::SensorState s(rejected);
  s.AddJoints({1000, {"a", "b"}, {0.0, 1.0}});
  s.AddJoints({2000, {"b", "a"}, {3.0, 1.0}});  // another order: names decide
  std::string reason;
  const auto v = s.JointsAt(1500, {"b", "a"}, 10'000, std::chrono::nanoseconds(0), &reason);
  ASSERT_TRUE(v) << reason;
  EXPECT_DOUBLE_EQ((*v)[0], 2.0);
  EXPECT_DOUBLE_EQ((*v)[1], 0.5);
  EXPECT_FALSE(s.JointsAt(1500, {"c"}, 10'000, std::chrono::nanoseconds(0), &reason));
  EXPECT_EQ(reason, "joint_states_missing_joint");
  EXPECT_FALSE(s.JointsAt(900'000, {"a"}, 10'000, std::chrono::nanoseconds(0), &reason));
  EXPECT_EQ(reason, "joint_states_too_far_from_image");
  s.AddJoints({1500, {"a", "b"}, {0.0, 0.0}});  // backwards in time
  EXPECT_EQ(rejected.Get("joint_states:stamp_not_increasing"), 1u);
}

TEST(SensorState, InterpolatesOdometryOnTheCircle) {
  CounterSet rejected;
  mapping::SensorState s(rejected);
  s.AddOdometry({0, 0, 0, 3.1});
  s.AddOdometry({100, 1, 0, -3.1});  // crossed +-pi
  std::string reason;
  const auto o = s.OdometryAt(50, 1000, std::chrono::nanoseconds(0), &reason);
  ASSERT_TRUE(o);
  EXPECT_NEAR(std::abs(o->theta), M_PI, 1e-9);
  EXPECT_NEAR(o->x, 0.5, 1e-12);
}

}  // namespace
}  // namespace epmap
