#include <gtest/gtest.h>

#include <limits>

#include "clients/sim/scenario.h"

namespace epmap::sim {
namespace {

std::string ErrorOf(const ScenarioOptions& o) {
  try {
    MakeScenario(o);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioOptions, BadInputIsRefusedWithTheReason) {
  ScenarioOptions o;
  o.name = "kitchen";
  EXPECT_NE(ErrorOf(o).find("unknown scenario 'kitchen'"), std::string::npos);
  EXPECT_NE(ErrorOf(o).find("head, vergence, building, eye-hand"), std::string::npos);
  o.name = "head";
  o.width = 0;
  o.height = 240;
  EXPECT_NE(ErrorOf(o).find("must both be positive"), std::string::npos);
  o.width = -320;
  EXPECT_NE(ErrorOf(o).find("must both be positive"), std::string::npos);
  o.width = 320;
  o.frames = -1;
  EXPECT_NE(ErrorOf(o).find("negative"), std::string::npos);
  o.frames = 0;
  o.reverse = true;
  EXPECT_NE(ErrorOf(o).find("building scenario only"), std::string::npos);
  o.reverse = false;
  o.passes = 2;
  EXPECT_NE(ErrorOf(o).find("--passes applies to the building scenario only"), std::string::npos);
  o.passes = 0;
  EXPECT_NE(ErrorOf(o).find("--passes must be within 1..100, got 0"), std::string::npos);
  o.passes = 1;
  o.route = "rooms";
  EXPECT_NE(ErrorOf(o).find("--route applies to the building scenario only"), std::string::npos);
  o.name = "building";
  o.route = "attic";
  EXPECT_NE(ErrorOf(o).find("unknown building route 'attic' (corridors or rooms)"),
            std::string::npos);
  o.name = "head";
  o.route = "corridors";
  o.walker = true;
  EXPECT_NE(ErrorOf(o).find("--walker applies to the building scenario only"), std::string::npos);
  o.walker = false;
  o.first_frame = 10;
  EXPECT_NE(ErrorOf(o).find("--first-frame applies to the building scenario only"),
            std::string::npos);
  o.name = "building";
  o.first_frame = -1;
  EXPECT_NE(ErrorOf(o).find("negative"), std::string::npos);
  o.first_frame = 100000;
  EXPECT_NE(ErrorOf(o).find("past its end"), std::string::npos);
  o.first_frame = 1800;
  o.frames = 100;
  EXPECT_NE(ErrorOf(o).find("from frame 1800"), std::string::npos);
  o.first_frame = 0;
  o.frames = 0;
  o.name = "head";
  o.encoder_noise_scale = -1;
  EXPECT_NE(ErrorOf(o).find(">= 0"), std::string::npos);
  o.encoder_noise_scale = 1;
  o.odometry_scale_error = 0.01;
  EXPECT_NE(ErrorOf(o).find("--odometry-scale-error applies to the building scenario only"),
            std::string::npos);
  o.odometry_scale_error = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(ErrorOf(o).find("within +-0.2"), std::string::npos);
  o.odometry_scale_error = 0.5;
  EXPECT_NE(ErrorOf(o).find("within +-0.2"), std::string::npos);
  o.odometry_scale_error = 0;
  o.supersample = 2;
  EXPECT_NE(ErrorOf(o).find("must be odd"), std::string::npos);
  o.supersample = 9;
  EXPECT_NE(ErrorOf(o).find("more than 7"), std::string::npos);
  o.supersample = 0;
  o.name = "eye-hand";
  EXPECT_NE(ErrorOf(o).find("no images"), std::string::npos);
  o.width = o.height = 0;
  o.supersample = 3;  // alone, it is refused too
  EXPECT_NE(ErrorOf(o).find("--supersample do not apply"), std::string::npos);
}

TEST(ScenarioOptions, ParsesImageSizes) {
  EXPECT_EQ(ParseImageSize("320x240"), std::make_pair(320, 240));
  EXPECT_EQ(ParseImageSize("640X480"), std::make_pair(640, 480));
  for (const char* bad :
       {"0x240", "320x0", "-3x4", "320", "x240", "320x", "axb", "320x240x3", "99999x2"}) {
    EXPECT_THROW(ParseImageSize(bad), std::invalid_argument) << bad;
  }
}

TEST(ScenarioOptions, IndexOutOfRangeIsAnError) {
  ScenarioOptions o;
  o.name = "head";
  o.frames = 2;
  o.width = 32;
  o.height = 24;
  const auto s = MakeScenario(o);
  EXPECT_THROW(s->Render(2), std::out_of_range);
  EXPECT_THROW(s->Render(-1), std::out_of_range);
  EXPECT_NO_THROW(s->Render(1));
}

}  // namespace
}  // namespace epmap::sim
