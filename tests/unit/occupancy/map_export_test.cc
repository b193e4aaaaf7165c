#include <gtest/gtest.h>

#include "perception/occupancy/map_export.h"

namespace epmap {
namespace {

occupancy::LayeredGrid Seen() {
  occupancy::LayeredGrid g;
  for (int k = 0; k < 6; ++k) g.AddPoint({0.05, 0.05, 1.0}, {2.05, 0.05, 1.0}, 0.01, {});
  return g;
}

TEST(Export, BytesUnknownWhereNothingWasSeenAndCroppedToTheKnownCells) {
  const auto e = Seen().Export();
  // Known cells run from x = 0 to 2.1 on one row; one cell of margin around.
  EXPECT_NEAR(e.origin_x, -0.1, 1e-9);
  EXPECT_NEAR(e.origin_y, -0.1, 1e-9);
  EXPECT_EQ(e.width, 23u);
  EXPECT_EQ(e.height, 3u);
  EXPECT_TRUE(e.combined);
  EXPECT_EQ(e.layer_count, 3u);
  ASSERT_EQ(e.occupancy.size(), 69u);
  const auto at = [&](int c, int r) { return e.occupancy[static_cast<size_t>(r) * e.width + c]; };
  EXPECT_EQ(at(0, 0), occupancy::GridExport::kUnknown);
  EXPECT_LT(at(6, 1), 20);   // x = 0.5: free
  EXPECT_GT(at(21, 1), 65);  // x = 2.0: occupied
  EXPECT_EQ(at(21, 2), occupancy::GridExport::kUnknown);
  EXPECT_GT(e.confidence[1 * e.width + 21], 0);
  EXPECT_EQ(Seen().Export(0).occupancy.size(), 0u);  // layer 0 saw nothing: an empty grid
}

TEST(Export, MapServerPgmAndYaml) {
  const auto e = Seen().Export();
  const std::string pgm = occupancy::EncodePgm(e);
  const std::string header = "P5\n23 3\n255\n";
  ASSERT_EQ(pgm.substr(0, header.size()), header);
  ASSERT_EQ(pgm.size(), header.size() + 69);
  // The image's top row is the highest y: data row 2 (unknown) first, then row 1.
  const auto pixel = [&](int c, int image_row) {
    return static_cast<uint8_t>(pgm[header.size() + static_cast<size_t>(image_row) * 23 + c]);
  };
  EXPECT_EQ(pixel(21, 0), 205);  // unknown
  EXPECT_LT(pixel(21, 1), 90);   // occupied: dark
  EXPECT_GT(pixel(6, 1), 200);   // free: light
  const std::string yaml = occupancy::MapServerYaml(e, "grid.pgm");
  EXPECT_NE(yaml.find("image: grid.pgm"), std::string::npos);
  EXPECT_NE(yaml.find("resolution: 0.100000"), std::string::npos);
  EXPECT_NE(yaml.find("origin: [-0.100000, -0.100000, 0.0]"), std::string::npos);
  EXPECT_NE(yaml.find("negate: 0"), std::string::npos);
  EXPECT_NE(yaml.find("occupied_thresh: 0.650"), std::string::npos);
  EXPECT_NE(yaml.find("free_thresh: 0.196"), std::string::npos);
  const cv::Mat picture = occupancy::RenderGrid(e, 4);
  EXPECT_EQ(picture.cols, 92);
  EXPECT_EQ(picture.rows, 12);
  occupancy::GridExport broken = e;
  broken.occupancy.pop_back();
  EXPECT_THROW(occupancy::EncodePgm(broken), std::invalid_argument);
}

}  // namespace
}  // namespace epmap
