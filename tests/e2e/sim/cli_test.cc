// epmap-sim as a user runs it: bad input gets a clear message and a non-zero exit, good input
// records a dataset the project's loader reads.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "common/dataset/dataset.h"
#include "tests/e2e/sim/run_command.h"
#include "tests/support/test_env.h"

namespace epmap::sim {
namespace {

namespace fs = std::filesystem;

std::string Sim() {
  return (epmap::testing::BinDir() / "epmap-sim").string();
}

TEST(EpmapSimCli, UnknownScenarioIsRefused) {
  const auto r = testing::RunCommand(Sim() + " record --scenario kitchen --out /tmp/never");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown scenario 'kitchen'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists("/tmp/never"));
}

TEST(EpmapSimCli, SizeThatIsNotPositiveIsRefused) {
  const auto dir = epmap::testing::FreshTempDir("sim-cli-size");
  for (const char* size : {"0x240", "320x-1", "320by240"}) {
    const auto r = testing::RunCommand(Sim() + " record --scenario head --size " + size +
                                       " --out " + (dir / "out").string());
    EXPECT_EQ(r.exit_code, 2) << size << ": " << r.output;
    EXPECT_NE(r.output.find("image size"), std::string::npos) << r.output;
  }
  fs::remove_all(dir);
}

TEST(EpmapSimCli, NonEmptyOutputFolderIsRefusedUnlessForced) {
  const auto dir = epmap::testing::FreshTempDir("sim-cli-force");
  std::ofstream(dir / "keep.txt") << "precious";
  const std::string cmd =
      Sim() + " record --scenario head --frames 2 --size 64x48 --out " + dir.string();
  const auto refused = testing::RunCommand(cmd);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("not empty"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("--force"), std::string::npos) << refused.output;
  EXPECT_TRUE(fs::exists(dir / "keep.txt"));
  const auto forced = testing::RunCommand(cmd + " --force");
  EXPECT_EQ(forced.exit_code, 0) << forced.output;
  EXPECT_FALSE(fs::exists(dir / "keep.txt"));
  const auto d = dataset::Load(dir);
  EXPECT_EQ(d.frames.size(), 2u);
  EXPECT_EQ(d.cam0.width, 64);
  fs::remove_all(dir);
}

TEST(EpmapSimCli, OtherBadFlagsAreRefused) {
  const auto dir = epmap::testing::FreshTempDir("sim-cli-flags");
  const std::string out = " --out " + (dir / "out").string();
  const auto reverse = testing::RunCommand(Sim() + " record --scenario head --reverse" + out);
  EXPECT_EQ(reverse.exit_code, 2) << reverse.output;
  EXPECT_NE(reverse.output.find("building scenario only"), std::string::npos);
  const auto route = testing::RunCommand(Sim() + " record --scenario building --route attic" + out);
  EXPECT_EQ(route.exit_code, 2) << route.output;
  EXPECT_NE(route.output.find("unknown building route 'attic' (corridors or rooms)"),
            std::string::npos)
      << route.output;
  const auto no_scenario = testing::RunCommand(Sim() + " record" + out);
  EXPECT_NE(no_scenario.exit_code, 0);
  EXPECT_NE(no_scenario.output.find("--scenario"), std::string::npos) << no_scenario.output;
  const auto eye_hand_size =
      testing::RunCommand(Sim() + " record --scenario eye-hand --size 320x240" + out);
  EXPECT_EQ(eye_hand_size.exit_code, 2);
  const auto bad_domain = testing::RunCommand(Sim() + " publish --scenario head --domain 999");
  EXPECT_NE(bad_domain.exit_code, 0);
  fs::remove_all(dir);
}

TEST(EpmapSimCli, RecordsEveryScenario) {
  const auto dir = epmap::testing::FreshTempDir("sim-cli-all");
  for (const std::string name : {"head", "vergence", "building"}) {
    const auto r =
        testing::RunCommand(Sim() + " record --scenario " + name +
                            " --frames 3 --size 80x60 --seed 7 --out " + (dir / name).string());
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.output;
    const auto d = dataset::Load(dir / name);
    EXPECT_EQ(d.frames.size(), 3u) << name;
    EXPECT_EQ(d.rectified(), name != "vergence") << name;
    EXPECT_TRUE(fs::exists(dir / name / "mav0/gt_extrinsics0/data.csv"));
  }
  // The rooms route starts where the corridors route does: the same first frame.
  const auto rooms =
      testing::RunCommand(Sim() +
                          " record --scenario building --route rooms --frames 3 --size "
                          "80x60 --seed 7 --out " +
                          (dir / "rooms").string());
  ASSERT_EQ(rooms.exit_code, 0) << rooms.output;
  EXPECT_EQ(dataset::Load(dir / "rooms").frames.size(), 3u);
  const auto first_image = [&](const std::string& name) {
    std::ifstream in(dir / name / "mav0/cam0/data.csv");
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    const std::string file = row.substr(row.find(',') + 1);
    std::ifstream png(dir / name / "mav0/cam0/data" / file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(png), {});
  };
  EXPECT_FALSE(first_image("rooms").empty());
  EXPECT_EQ(first_image("rooms"), first_image("building"));
  const auto r = testing::RunCommand(Sim() + " record --scenario eye-hand --out " +
                                     (dir / "eye-hand").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream samples(dir / "eye-hand/mav0/samples.csv");
  std::string header;
  std::getline(samples, header);
  EXPECT_EQ(header, "#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path");
  int rows = 0;
  for (std::string line; std::getline(samples, line);) ++rows;
  EXPECT_EQ(rows, 2000);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace epmap::sim
