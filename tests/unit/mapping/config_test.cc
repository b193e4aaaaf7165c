#include <gtest/gtest.h>

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

}  // namespace
}  // namespace epmap
