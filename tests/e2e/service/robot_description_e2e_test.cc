// The URDF from a latched ROS 2 topic: a test participant plays robot_state_publisher (the
// pan-head robot's URDF as std_msgs/String on rt/robot_description, reliable + transient local,
// written before epmapd starts) and a real epmapd takes its kinematic chain from it. Nothing on
// the topic, a text that is not a URDF, or one over 16 MiB is a clear startup error (exit 1); a
// 12 MiB one is taken whole.

#include <epmap_dds/StringPubSubTypes.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "common/dds/endpoints.h"
#include "common/dds/participant.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap {
namespace {

namespace fs = std::filesystem;
using std::chrono::seconds;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// robot_state_publisher's side: the description, latched.
class DescriptionPublisher {
 public:
  DescriptionPublisher(uint32_t domain, const std::string& topic, std::string text)
      : participant_(domain, "robot-state-publisher-test"),
        writer_(participant_, topic, 1, dds::Durability::kTransientLocal) {
    std_msgs::msg::String msg;
    msg.data(std::move(text));
    EXPECT_TRUE(writer_.Write(msg));
  }

 private:
  dds::Participant participant_;
  dds::Writer<std_msgs::msg::String, std_msgs::msg::StringPubSubType> writer_;
};

std::pair<int, std::string> CheckRobot(const fs::path& work, std::vector<std::string> args) {
  args.insert(args.begin(), "--check-robot");
  return testing::RunToCompletion(testing::BinDir() / "epmapd", args, work / "check.log",
                                  seconds(60));
}

TEST(RobotDescriptionE2E, TheLatchedDescriptionIsTheServicesUrdf) {
  const auto work = testing::FreshTempDir("robot-description");
  const uint32_t domain = testing::UniqueDomainId(71);
  const std::string urdf = ReadText(testing::SourceDir() / "clients/sim/urdf/pan_robot.urdf");
  ASSERT_NE(urdf.find("<robot"), std::string::npos);
  {
    // A large one (12 MiB: meshes pasted in as comments) under the 16 MiB limit is taken whole.
    std::string large = urdf;
    large.insert(large.rfind("</robot>"), "<!--" + std::string(12u << 20, 'm') + "-->\n");
    DescriptionPublisher publisher(domain, "rt/large_description", large);
    const auto [code, out] =
        CheckRobot(work, {"--domain", std::to_string(domain), "--urdf-topic",
                          "rt/large_description", "--state-dir", (work / "large-state").string()});
    ASSERT_EQ(code, 0) << out;
    EXPECT_NE(out.find("root link (the base): base_link"), std::string::npos) << out;
    EXPECT_EQ(ReadText(work / "large-state" / "robot_description.urdf"), large);
  }
  // Written before any epmapd exists: only a transient-local reader gets it.
  DescriptionPublisher publisher(domain, "rt/robot_description", urdf);

  const auto [code, out] =
      CheckRobot(work, {"--domain", std::to_string(domain), "--urdf-topic", "rt/robot_description",
                        "--state-dir", (work / "check-state").string()});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("robot description from rt/robot_description"), std::string::npos) << out;
  EXPECT_NE(out.find("root link (the base): base_link"), std::string::npos) << out;
  EXPECT_NE(out.find("baseline at zero joints: 0.1200 m"), std::string::npos) << out;

  // The service: with a URDF (and no odometry) `auto` is the head mode; without one it would be
  // static. The description is kept in the state folder, as published.
  const auto state = work / "state";
  testing::Epmapd epmapd(
      domain, {"--urdf-topic", "rt/robot_description", "--state-dir", state.string()}, work);
  ASSERT_TRUE(epmapd.WaitReady()) << epmapd.process().Output();
  v1::ServiceStatus status;
  ASSERT_TRUE(epmapd.Status(&status).ok());
  EXPECT_EQ(status.mode(), "head") << status.DebugString();
  // GetStatus says which chain the service uses, from the kept file.
  ASSERT_TRUE(status.has_robot()) << status.DebugString();
  EXPECT_EQ(status.robot().urdf(), (state / "robot_description.urdf").string());
  EXPECT_EQ(status.robot().root_link(), "base_link");
  EXPECT_EQ(status.robot().left_camera_link(), "cam0_optical");
  EXPECT_EQ(status.robot().right_camera_link(), "cam1_optical");
  ASSERT_EQ(status.robot().joints_size(), 1);
  EXPECT_EQ(status.robot().joints(0), "pan");
  EXPECT_EQ(status.robot().pose_source(), "urdf");
  EXPECT_EQ(ReadText(state / "robot_description.urdf"), urdf);
  fs::remove_all(work);
}

TEST(RobotDescriptionE2E, NothingOnTheTopicOrNoUrdfIsAClearStartupError) {
  const auto work = testing::FreshTempDir("robot-description-bad");
  const uint32_t domain = testing::UniqueDomainId(72);
  const auto config = work / "epmapd.yaml";
  std::ofstream(config) << "robot:\n  urdf_topic_wait_ms: 1500\n";
  {
    const auto [code, out] =
        CheckRobot(work, {"--config", config.string(), "--domain", std::to_string(domain),
                          "--urdf-topic", "rt/robot_description"});
    EXPECT_EQ(code, 1) << out;
    EXPECT_NE(out.find("no robot description on rt/robot_description"), std::string::npos) << out;
    EXPECT_NE(out.find("robot_state_publisher"), std::string::npos) << out;
  }
  {
    DescriptionPublisher publisher(domain, "rt/not_a_description", "just some text");
    const auto [code, out] =
        CheckRobot(work, {"--config", config.string(), "--domain", std::to_string(domain),
                          "--urdf-topic", "rt/not_a_description"});
    EXPECT_EQ(code, 1) << out;
    EXPECT_NE(out.find("is not a URDF <robot>"), std::string::npos) << out;
  }
  {
    // A description over the 16 MiB the service takes (a URDF with meshes pasted in, say) is
    // refused by its size, before it is decoded.
    std::string huge = "<robot name=\"huge\"><!--";
    huge.append((17u << 20) - huge.size(), 'x');
    huge += "--></robot>";
    DescriptionPublisher publisher(domain, "rt/huge_description", std::move(huge));
    const auto [code, out] =
        CheckRobot(work, {"--config", config.string(), "--domain", std::to_string(domain),
                          "--urdf-topic", "rt/huge_description"});
    EXPECT_EQ(code, 1) << out;
    EXPECT_NE(out.find("is larger than 16 MiB"), std::string::npos) << out;
  }
  // A file and a topic at once in the config is a configuration error (exit 2).
  std::ofstream(config) << "robot:\n  urdf: robot.urdf\n  urdf_topic: rt/robot_description\n";
  const auto [code, out] = CheckRobot(work, {"--config", config.string()});
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("exclusive"), std::string::npos) << out;
  fs::remove_all(work);
}

}  // namespace
}  // namespace epmap
