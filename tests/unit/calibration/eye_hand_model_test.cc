// Models survive a JSON round trip bit for bit, bad JSON is refused, and the samples CSV reads
// back what was written.

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "perception/calibration/eye_hand_calibration.h"
#include "tests/support/test_env.h"
#include "tests/unit/calibration/synthetic_eye_hand.h"

namespace epmap::calibration {
namespace {

TEST(EyeHandModel, JsonRoundTripIsExactForEveryMethod) {
  const auto samples = testing::MakeEyeHandSamples({});
  for (auto method : {EyeHandMethod::kSe3, EyeHandMethod::kSe3Scale, EyeHandMethod::kMixture}) {
    EyeHandCalibrationParams p;
    p.method = method;
    const EyeHandModel model = CalibrateEyeHand(samples, {}, p).model;
    const EyeHandModel back = EyeHandModel::FromJson(model.ToJson());
    EXPECT_EQ(back.method(), method);
    ASSERT_EQ(back.experts().size(), model.experts().size());
    for (const auto& s : samples) EXPECT_EQ(back.Apply(s.xa), model.Apply(s.xa));
  }
}

TEST(EyeHandModel, RefusesMalformedOrInvalidJson) {
  const std::string good = EyeHandModel().ToJson();
  EXPECT_NO_THROW(EyeHandModel::FromJson(good));
  for (const std::string& bad :
       {std::string("{"), std::string("[]"), std::string("{\"type\":\"stereo-extrinsics\"}"),
        std::string(
            "{\"type\":\"eye-hand\",\"format_version\":1,\"method\":\"se3\",\"experts\":"
            "[{\"rotation\":[2,0,0,0,1,0,0,0,1],\"scale\":[1,1,1],\"translation\":[0,0,0]}]}"),
        std::string(
            "{\"type\":\"eye-hand\",\"format_version\":1,\"method\":\"magic\",\"experts\":[]}")}) {
    try {
      EyeHandModel::FromJson(bad);
      FAIL() << "accepted: " << bad;
    } catch (const CalibrationError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidInput) << bad;
    }
  }
}

TEST(EyeHandSamples, CsvRoundTripAndErrors) {
  testing::SyntheticEyeHandParams p;
  p.paths = 2;
  const auto samples = testing::MakeEyeHandSamples(p);
  const auto dir = ::epmap::testing::FreshTempDir("calib-csv");
  WriteEyeHandCsv(dir / "s.csv", samples);
  const auto back = ReadEyeHandCsv(dir / "s.csv");
  ASSERT_EQ(back.size(), samples.size());
  EXPECT_EQ(back[7].path, samples[7].path);
  EXPECT_EQ(back[7].stamp_ns, samples[7].stamp_ns);
  EXPECT_LT((back[7].xa - samples[7].xa).norm(), 1e-8);
  EXPECT_EQ(PathNames(back).size(), 2u);
  {
    std::ofstream bad(dir / "bad.csv");
    bad << "#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path\n1,0,0,0,0,0,zero,p\n";
  }
  try {
    ReadEyeHandCsv(dir / "bad.csv");
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadEyeHandCsv(dir / "missing.csv"), CalibrationError);
  std::filesystem::remove_all(dir);
}

TEST(EyeHandSamples, SplitByPathsIsDeterministicAndKeepsPathsWhole) {
  const auto samples = testing::MakeEyeHandSamples({});
  const PathSplit a = SplitByPaths(samples, 0.25, 3);
  const PathSplit b = SplitByPaths(samples, 0.25, 3);
  EXPECT_EQ(a.test_paths, b.test_paths);
  ASSERT_EQ(a.test_paths.size(), 5u);
  EXPECT_EQ(a.train.size() + a.test.size(), samples.size());
  for (const auto& s : a.train) {
    EXPECT_EQ(std::count(a.test_paths.begin(), a.test_paths.end(), s.path), 0);
  }
  EXPECT_NE(SplitByPaths(samples, 0.25, 4).test_paths, a.test_paths);
  testing::SyntheticEyeHandParams one;
  one.paths = 1;
  EXPECT_THROW(SplitByPaths(testing::MakeEyeHandSamples(one), 0.5, 1), CalibrationError);
  EXPECT_THROW(SplitByPaths(samples, 1.0, 1), CalibrationError);
}

}  // namespace
}  // namespace epmap::calibration
