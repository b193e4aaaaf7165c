#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>

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

// A local planner's window: exactly the cells the box overlaps, on the map's own lattice, the
// same bytes as the whole map where they overlap, unknown where the map has no cell.
TEST(Export, AWindowIsTheMapsOwnCellsOverTheBoxAndUnknownBeyondIt) {
  const auto g = Seen();
  const auto whole = g.Export();
  // A box from x = 1.52 to 3.0 and y = -0.3 to 0.25: cells 15..29 along x, -3..2 along y.
  const auto window = occupancy::WindowOverBox(0.1, 1.52, -0.3, 3.0, 0.25);
  EXPECT_EQ(window.ix0, 15);
  EXPECT_EQ(window.iy0, -3);
  EXPECT_EQ(window.width, 15u);  // 3.0 is a cell edge: cell 30 is not taken
  EXPECT_EQ(window.height, 6u);
  const auto e = g.ExportWindow(window);
  EXPECT_NEAR(e.origin_x, 1.5, 1e-9);
  EXPECT_NEAR(e.origin_y, -0.3, 1e-9);
  ASSERT_EQ(e.width, 15u);
  ASSERT_EQ(e.height, 6u);
  ASSERT_EQ(e.occupancy.size(), 90u);
  ASSERT_EQ(e.confidence.size(), 90u);
  EXPECT_TRUE(e.combined);
  EXPECT_EQ(e.combined_layers, 3u);
  size_t compared = 0;
  for (uint32_t r = 0; r < e.height; ++r) {
    for (uint32_t c = 0; c < e.width; ++c) {
      // The same world cell in the whole map's export, if it holds it.
      const long wc = 15 + static_cast<long>(c) - std::lround(whole.origin_x / 0.1);
      const long wr = -3 + static_cast<long>(r) - std::lround(whole.origin_y / 0.1);
      const size_t i = static_cast<size_t>(r) * e.width + c;
      if (wc < 0 || wr < 0 || wc >= static_cast<long>(whole.width) ||
          wr >= static_cast<long>(whole.height)) {
        EXPECT_EQ(e.occupancy[i], occupancy::GridExport::kUnknown) << c << "," << r;
        EXPECT_EQ(e.confidence[i], 0) << c << "," << r;
        continue;
      }
      const size_t j = static_cast<size_t>(wr) * whole.width + static_cast<size_t>(wc);
      EXPECT_EQ(e.occupancy[i], whole.occupancy[j]) << c << "," << r;
      EXPECT_EQ(e.confidence[i], whole.confidence[j]) << c << "," << r;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 7u * 3u);  // the whole map ends at x = 2.2: cells 15..21, rows -1..1
  EXPECT_GT(e.occupancy[3 * e.width + 5], 65);  // x = 2.0, y = 0: the point's cell, occupied
  // One layer, and the bands a low robot can hit, the same way.
  const auto layer1 = g.ExportWindow(window, 1);  // the points are 1 m up: band 0.7-1.3 m
  EXPECT_FALSE(layer1.combined);
  EXPECT_EQ(layer1.layer, 1u);
  EXPECT_GT(layer1.occupancy[3 * e.width + 5], 65);
  const auto layer2 = g.ExportWindow(window, 2);  // nothing seen up there
  EXPECT_EQ(std::count(layer2.occupancy.begin(), layer2.occupancy.end(), 255), 90);
  EXPECT_EQ(g.ExportBelowWindow(window, 3).occupancy, e.occupancy);
  EXPECT_THROW(g.ExportWindow(window, 3), std::out_of_range);
  EXPECT_THROW(g.ExportBelowWindow(window, 0), std::out_of_range);
  // A window wholly away from the map, and an empty map: all unknown, the size asked for.
  const auto away = g.ExportWindow(occupancy::WindowOverBox(0.1, 40, 40, 41, 41));
  EXPECT_EQ(away.width * away.height, 100u);
  EXPECT_EQ(std::count(away.occupancy.begin(), away.occupancy.end(), 255), 100);
  EXPECT_EQ(occupancy::LayeredGrid().ExportWindow(window).occupancy.size(), 90u);
}

TEST(Export, ABoxThatIsNoWindowIsRefused) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(occupancy::WindowOverBox(0.1, nan, 0, 1, 1), std::invalid_argument);
  EXPECT_THROW(occupancy::WindowOverBox(0.1, 0, 0, inf, 1), std::invalid_argument);
  EXPECT_THROW(occupancy::WindowOverBox(0.1, 1, 0, 1, 1), std::invalid_argument);  // min = max
  EXPECT_THROW(occupancy::WindowOverBox(0.1, 0, 2, 1, 1), std::invalid_argument);  // min > max
  EXPECT_THROW(occupancy::WindowOverBox(0.0, 0, 0, 1, 1), std::invalid_argument);  // resolution
  EXPECT_THROW(occupancy::WindowOverBox(0.1, 0, 0, 1e300, 1), std::invalid_argument);
  EXPECT_THROW(occupancy::WindowOverBox(0.1, 0, 0, 100.01, 1, 1000), std::invalid_argument);
  EXPECT_EQ(occupancy::WindowOverBox(0.1, 0, 0, 100, 1, 1000).width, 1000u);
  // Negative coordinates snap down, as the lattice does; a sliver of a cell is one cell.
  const auto w = occupancy::WindowOverBox(0.1, -0.25, -0.01, -0.24, 0.0);
  EXPECT_EQ(w.ix0, -3);
  EXPECT_EQ(w.iy0, -1);
  EXPECT_EQ(w.width, 1u);
  EXPECT_EQ(w.height, 1u);
}

// The export reads the planes row by row; every byte must be what the cell reads through At()
// and Combined() gives: for the combined map, each band, the bands a low robot can hit, and a
// window, on a grid of random rays.
TEST(Export, RowByRowGivesTheBytesOfEveryCellAsAtAndCombinedRead) {
  occupancy::LayeredGrid g;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-4.0, 4.0), z(0.05, 2.1);
  for (int k = 0; k < 400; ++k) {
    g.AddPoint({xy(rng) / 4, xy(rng) / 4, 1.0}, {xy(rng), xy(rng), z(rng)}, 0.02, {});
  }
  const auto bytes_of = [](const occupancy::Cell& cell, double unknown_below) {
    const uint8_t k =
        static_cast<uint8_t>(std::lround(255.0 * std::clamp(cell.confidence, 0.0F, 1.0F)));
    if (cell.confidence < unknown_below) return std::pair<uint8_t, uint8_t>(255, k);
    const double occ = std::clamp(50.0 + 50.0 * (cell.occupied - cell.empty), 0.0, 100.0);
    return std::pair<uint8_t, uint8_t>(static_cast<uint8_t>(std::lround(occ)), k);
  };
  // Every cell of e against read(ix, iy).
  const auto check = [&](const occupancy::GridExport& e, const auto& read, const char* what) {
    ASSERT_GT(e.width * e.height, 100u) << what;
    size_t differ = 0;
    for (uint32_t r = 0; r < e.height; ++r) {
      for (uint32_t c = 0; c < e.width; ++c) {
        const int64_t ix = std::lround(e.origin_x / e.resolution_m) + c;
        const int64_t iy = std::lround(e.origin_y / e.resolution_m) + r;
        const auto [occ, conf] = bytes_of(read(ix, iy), 0.05);
        const size_t i = static_cast<size_t>(r) * e.width + c;
        differ += e.occupancy[i] != occ || e.confidence[i] != conf;
      }
    }
    EXPECT_EQ(differ, 0u) << what;
  };
  check(
      g.Export(), [&](int64_t ix, int64_t iy) { return g.Combined(ix, iy); }, "combined");
  for (int l = 0; l < g.layer_count(); ++l) {
    check(
        g.Export(l), [&](int64_t ix, int64_t iy) { return g.At(l, ix, iy); }, "a layer");
  }
  check(
      g.ExportBelow(2), [&](int64_t ix, int64_t iy) { return g.Combined(ix, iy, 2); },
      "the lowest two bands");
  const auto window = occupancy::WindowOverBox(0.1, -6, -1, 2, 7);  // reaches past the grid
  check(
      g.ExportWindow(window), [&](int64_t ix, int64_t iy) { return g.Combined(ix, iy); },
      "a window");
  check(
      g.ExportWindow(window, 1), [&](int64_t ix, int64_t iy) { return g.At(1, ix, iy); },
      "a window of a layer");
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
