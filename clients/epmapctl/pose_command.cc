// epmapctl pose [--json]: the mobile base's odometry pose, its visually corrected pose (paper
// 002) and their difference (corrected - odometry), metres and radians in the world frame
// (the robot's start pose).

#include <cmath>
#include <cstdio>
#include <numbers>

#include "clients/epmapctl/client.h"
#include "epmap/v1/map_service.grpc.pb.h"

namespace {

using epmap::ctl::ClientOptions;

std::string Pose(const epmap::v1::Pose2D& p) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "{\"x\":%.4f,\"y\":%.4f,\"theta\":%.6f}", p.x(), p.y(), p.theta());
  return buf;
}

int Run(const ClientOptions& options, bool json, const epmap::ctl::MapsWait& wait) {
  auto stub = epmap::v1::MapService::NewStub(options.Channel());
  epmap::v1::PoseEstimate pose;
  epmap::v1::GetPoseRequest request;
  wait.Apply(&request);
  const auto context = options.Context(wait.wait_ms);
  const grpc::Status rpc = stub->GetPose(context.get(), request, &pose);
  if (!rpc.ok()) return options.Fail(rpc);
  if (json) {
    std::printf(
        "{\"stamp_ns\":%lld,\"odometry\":%s,\"corrected\":%s,\"difference\":%s,"
        "\"keyframes\":%u,\"registrations\":%u,\"resumed_unconfirmed\":%s}\n",
        static_cast<long long>(pose.stamp_ns()), Pose(pose.odometry()).c_str(),
        Pose(pose.corrected()).c_str(), Pose(pose.difference()).c_str(), pose.keyframes(),
        pose.registrations(), pose.resumed_unconfirmed() ? "true" : "false");
    return 0;
  }
  constexpr double kDeg = 180.0 / std::numbers::pi;
  const auto line = [&](const char* name, const epmap::v1::Pose2D& p) {
    std::printf("%-10s x %8.3f m  y %8.3f m  theta %8.3f deg\n", name, p.x(), p.y(),
                p.theta() * kDeg);
  };
  std::printf("stamp %lld ns, %u key frames, %u registrations%s\n",
              static_cast<long long>(pose.stamp_ns()), pose.keyframes(), pose.registrations(),
              pose.resumed_unconfirmed() ? epmap::ctl::kResumedNote : "");
  line("odometry", pose.odometry());
  line("corrected", pose.corrected());
  line("difference", pose.difference());
  return 0;
}

void Setup(CLI::App& app, ClientOptions& options) {
  auto* cmd = app.add_subcommand("pose", "odometry, corrected pose and difference (mobile base)");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "one JSON object instead of text");
  auto wait = std::make_shared<epmap::ctl::MapsWait>();
  wait->AddOptions(cmd);
  cmd->callback([&options, json, wait] { options.exit_code = Run(options, *json, *wait); });
}

}  // namespace

EPMAP_CTL_COMMAND(pose, Setup);
