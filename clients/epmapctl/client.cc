#include "clients/epmapctl/client.h"

#include <chrono>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

namespace epmap::ctl {

std::shared_ptr<grpc::Channel> ClientOptions::Channel() const {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(256 << 20);  // maps can be larger than gRPC's 4 MiB default
  args.SetMaxSendMessageSize(64 << 20);
  return grpc::CreateCustomChannel(server, grpc::InsecureChannelCredentials(), args);
}

std::unique_ptr<grpc::ClientContext> ClientOptions::Context(uint32_t server_wait_ms) const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000) +
                                                  static_cast<int64_t>(server_wait_ms)));
  return context;
}

void MapsWait::AddOptions(CLI::App* command) {
  command->add_option("--newer-than", newer_than_ns,
                      "only maps stamped after this (ns; the stamp_ns of the maps you have)");
  command
      ->add_option("--wait-ms", wait_ms,
                   "wait this long (max 30000) for such maps; without it: at once")
      ->check(CLI::Range(0u, 30000u));
}

void MapWindow::AddOptions(CLI::App* command, const std::string& what_is_kept) {
  auto* box = command
                  ->add_option("--region", region,
                               "only " + what_is_kept +
                                   " in this box of the world frame: MIN_X,MIN_Y,MAX_X,MAX_Y (m)")
                  ->delimiter(',')
                  ->expected(4);
  command
      ->add_option("--around-robot", around_robot_m,
                   "only " + what_is_kept +
                       " in a square of this side (m) centred on the robot's corrected pose")
      ->excludes(box);
}

namespace {
const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    default:
      return "ERROR";
  }
}
}  // namespace

int ClientOptions::Fail(const grpc::Status& status) const {
  std::cerr << "epmapctl: " << CodeName(status.error_code()) << ": " << status.error_message();
  if (status.error_code() == grpc::StatusCode::UNAVAILABLE &&
      status.error_message().find("connect") != std::string::npos) {
    std::cerr << " (is epmapd running on " << server << "?)";
  }
  std::cerr << "\n";
  return 1;
}

std::vector<CommandSetup>& CommandSetups() {
  static std::vector<CommandSetup> setups;
  return setups;
}

void WriteImageFile(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image)) throw std::runtime_error("cannot write " + path);
}

}  // namespace epmap::ctl
