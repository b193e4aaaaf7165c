#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "services/mapping/config/service_config.h"
#include "tests/support/test_env.h"

namespace epmap {
namespace {

using mapping::ServiceConfig;

// deploy/epmapd.yaml documents every setting with its default: loading it must give exactly
// the built-in defaults, so the two can never drift apart.
TEST(ServiceConfig, ShippedYamlEqualsTheDefaults) {
  const auto shipped = mapping::LoadServiceConfig(testing::SourceDir() / "deploy/epmapd.yaml");
  EXPECT_EQ(mapping::ToYaml(shipped), mapping::ToYaml(ServiceConfig{}));
  EXPECT_NO_THROW(shipped.Validate());
}

TEST(ServiceConfig, ToYamlRoundTrips) {
  ServiceConfig c;
  c.listen = "0.0.0.0:6000";
  c.sgbm.num_disparities = 128;
  c.pair_tolerance_ns = 3'500'000;
  c.topics.left_image = "rt/cam/left";
  ServiceConfig back;
  mapping::ApplyYaml(mapping::ToYaml(c), back);
  EXPECT_EQ(mapping::ToYaml(back), mapping::ToYaml(c));
  EXPECT_EQ(back.pair_tolerance_ns, 3'500'000);
}

TEST(ServiceConfig, UnknownKeysAndBadValuesAreClearErrors) {
  ServiceConfig c;
  try {
    mapping::ApplyYaml("stereo:\n  num_disparites: 64\n", c);
    FAIL() << "a typo must not pass";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("stereo.num_disparites"), std::string::npos);
  }
  EXPECT_THROW(mapping::ApplyYaml("stereo: 5\n", c), std::invalid_argument);
  EXPECT_THROW(mapping::ApplyYaml("stereo:\n  num_disparities: many\n", c), std::invalid_argument);
  ServiceConfig bad;
  bad.sgbm.num_disparities = 40;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = ServiceConfig{};
  bad.mode = "flying";
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = ServiceConfig{};
  bad.listen = "nowhere";
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

TEST(ServiceConfig, EmptySectionsKeepDefaults) {
  ServiceConfig c;
  mapping::ApplyYaml("robot:\nstereo:\n  block_size: 7\n", c);
  EXPECT_EQ(c.sgbm.block_size, 7);
  EXPECT_EQ(c.mode, "auto");
}

// Validate() must refuse the configuration with a message naming the key.
void ExpectRefusedNaming(const ServiceConfig& c, const std::string& key) {
  try {
    c.Validate();
    ADD_FAILURE() << key << " must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}

// The maps section (mobile-base mode): read from YAML, and bad values named.
TEST(ServiceConfig, MapsSectionIsReadAndChecked) {
  ServiceConfig c;
  mapping::ApplyYaml("maps:\n  key_frame_min_translation_m: 0.5\n  visual_heading: false\n", c);
  EXPECT_DOUBLE_EQ(c.maps.key_frame_min_translation_m, 0.5);
  EXPECT_FALSE(c.maps.visual_heading);
  EXPECT_NO_THROW(c.Validate());
  c.maps.view_min_key_frames = -1;
  ExpectRefusedNaming(c, "maps.view_min_key_frames");
  mapping::ApplyYaml("maps:\n  odometry_drift_per_m: 0\n  place_views_by_pose: false\n", c);
  EXPECT_EQ(c.maps.odometry_drift_per_m, 0.0);
  EXPECT_FALSE(c.maps.place_views_by_pose);
  ServiceConfig e;
  e.maps.odometry_drift_per_m = -0.01;
  ExpectRefusedNaming(e, "maps.odometry_drift_per_m");
  ServiceConfig off;
  EXPECT_EQ(off.maps.heading_registration_step_deg, 0.5);
  mapping::ApplyYaml("maps:\n  heading_registration_step_deg: 0\n", off);
  EXPECT_EQ(off.maps.heading_registration_step_deg, 0.0);
  EXPECT_NO_THROW(off.Validate());
  for (const double bad : {-0.5, 6.0, std::nan("")}) {
    ServiceConfig h;
    h.maps.heading_registration_step_deg = bad;
    ExpectRefusedNaming(h, "maps.heading_registration_step_deg");
  }
  ServiceConfig fine;
  mapping::ApplyYaml("maps:\n  grid_resolution_m: 0.05\n", fine);
  EXPECT_DOUBLE_EQ(fine.maps.grid_resolution_m, 0.05);
  EXPECT_NO_THROW(fine.Validate());
  for (const double bad : {0.0, -0.1, 0.01, 2.0, std::nan("")}) {
    ServiceConfig g;
    g.maps.grid_resolution_m = bad;
    ExpectRefusedNaming(g, "maps.grid_resolution_m");
  }
  ServiceConfig d;
  d.maps.max_odometry_step_m = -1;
  EXPECT_THROW(d.Validate(), std::invalid_argument);
  EXPECT_THROW(mapping::ApplyYaml("maps:\n  key_frame_min_translation: 0.5\n", d),
               std::invalid_argument);
}

TEST(ServiceConfig, RosOutputTopicsAndFramesAreReadAndChecked) {
  ServiceConfig c;
  mapping::ApplyYaml(
      "dds:\n  topics:\n    map: \"rt/robot1/map\"\n    tf: \"\"\n"
      "    perceptual_map: \"rt/robot1/pmap\"\n"
      "maps:\n  map_frame: \"robot1_map\"\n  grid_publish_period_s: 2.5\n",
      c);
  EXPECT_EQ(c.topics.map, "rt/robot1/map");
  EXPECT_TRUE(c.topics.tf.empty());  // empty: tf not published
  EXPECT_EQ(c.topics.perceptual_map, "rt/robot1/pmap");
  EXPECT_EQ(c.maps.map_frame, "robot1_map");
  EXPECT_EQ(c.maps.odom_frame, "odom");
  EXPECT_DOUBLE_EQ(c.maps.grid_publish_period_s, 2.5);
  EXPECT_NO_THROW(c.Validate());
  c.maps.odom_frame = "robot1_map";
  try {
    c.Validate();
    FAIL() << "map_frame == odom_frame must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("maps.map_frame"), std::string::npos) << e.what();
  }
  ServiceConfig d;
  d.maps.grid_publish_period_s = 0;
  EXPECT_THROW(d.Validate(), std::invalid_argument);
}

TEST(ServiceConfig, DurableMapsSettings) {
  ServiceConfig c;
  EXPECT_TRUE(c.maps.persist);
  mapping::ApplyYaml("maps:\n  persist: false\n  save_period_s: 30\n", c);
  EXPECT_FALSE(c.maps.persist);
  EXPECT_DOUBLE_EQ(c.maps.save_period_s, 30);
  EXPECT_NO_THROW(c.Validate());
  ServiceConfig back;
  mapping::ApplyYaml(mapping::ToYaml(c), back);
  EXPECT_FALSE(back.maps.persist);
  EXPECT_DOUBLE_EQ(back.maps.save_period_s, 30);
  c.maps.save_period_s = -1;
  EXPECT_THROW(c.Validate(), std::invalid_argument);
}

TEST(ServiceConfig, CameraLinksOfARobotsOwnUrdf) {
  ServiceConfig c;
  EXPECT_EQ(c.left_camera_link, "cam0_optical");  // the dataset layout's names by default
  EXPECT_EQ(c.right_camera_link, "cam1_optical");
  mapping::ApplyYaml(
      "robot:\n  left_camera_link: \"zed_left_camera_optical_frame\"\n"
      "  right_camera_link: \"zed_right_camera_optical_frame\"\n",
      c);
  EXPECT_EQ(c.left_camera_link, "zed_left_camera_optical_frame");
  EXPECT_EQ(c.right_camera_link, "zed_right_camera_optical_frame");
  EXPECT_NO_THROW(c.Validate());
  ServiceConfig back;
  mapping::ApplyYaml(mapping::ToYaml(c), back);
  EXPECT_EQ(back.left_camera_link, c.left_camera_link);
  for (const auto& [left, right] : {std::pair{"", "cam1_optical"}, std::pair{"cam", "cam"}}) {
    ServiceConfig bad;
    bad.left_camera_link = left;
    bad.right_camera_link = right;
    try {
      bad.Validate();
      ADD_FAILURE() << "accepted left '" << left << "', right '" << right << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("robot.left_camera_link"), std::string::npos)
          << e.what();
    }
  }
}

TEST(ServiceConfig, TheUrdfFromAFileOrALatchedTopic) {
  ServiceConfig c;
  mapping::ApplyYaml("robot:\n  urdf_topic: rt/robot_description\n  urdf_topic_wait_ms: 2500\n", c);
  EXPECT_EQ(c.urdf_topic, "rt/robot_description");
  EXPECT_EQ(c.urdf_topic_wait_ns, 2'500'000'000);
  EXPECT_NO_THROW(c.Validate());
  ServiceConfig back;
  mapping::ApplyYaml(mapping::ToYaml(c), back);
  EXPECT_EQ(back.urdf_topic, c.urdf_topic);
  EXPECT_EQ(back.urdf_topic_wait_ns, c.urdf_topic_wait_ns);
  ServiceConfig both = c;
  both.urdf = "robot.urdf";
  EXPECT_THROW(both.Validate(), std::invalid_argument);
  ServiceConfig no_wait = c;
  no_wait.urdf_topic_wait_ns = 0;
  EXPECT_THROW(no_wait.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
