#pragma once
// Starts a real epmapd process on a free port and this test's own DDS domain, and gives a
// gRPC stub to it. Used by the end-to-end tests.

#include <epmap/v1/map_service.grpc.pb.h>
#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <vector>

#include "common/process/child_process.h"
#include "tests/support/test_env.h"

namespace epmap::testing {

using process::ChildProcess;
using process::FreeTcpPort;
using process::RunToCompletion;

class Epmapd {
 public:
  // Extra arguments go after --listen and --domain.
  Epmapd(uint32_t domain, const std::vector<std::string>& extra_args,
         const std::filesystem::path& work_dir)
      : domain_(domain), port_(FreeTcpPort()), address_("127.0.0.1:" + std::to_string(port_)) {
    std::vector<std::string> args = {"--listen", address_, "--domain", std::to_string(domain)};
    args.insert(args.end(), extra_args.begin(), extra_args.end());
    process_ = std::make_unique<ChildProcess>(BinDir() / "epmapd", args, work_dir / "epmapd.log");
    Connect();
  }

  // Waits until GetStatus answers; false if the process died or the time ran out.
  bool WaitReady(std::chrono::seconds timeout = std::chrono::seconds(20)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (!process_->running()) return false;
      v1::ServiceStatus status;
      if (Status(&status).ok()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      // A new channel each attempt: one that failed while epmapd was starting sits in gRPC's
      // reconnect backoff (1 s, then x1.6), which made this wait ~5 s.
      Connect();
    }
    return false;
  }

  grpc::Status Status(v1::ServiceStatus* out) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    return stub_->GetStatus(&context, {}, out);
  }

  // Polls status until `done` holds or the timeout passes; returns the last status.
  template <class Predicate>
  v1::ServiceStatus WaitStatus(Predicate done, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    v1::ServiceStatus status;
    while (std::chrono::steady_clock::now() < deadline) {
      status.Clear();
      if (Status(&status).ok() && done(status)) return status;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return status;
  }

  static uint64_t Count(const google::protobuf::RepeatedPtrField<v1::Counter>& counters,
                        const std::string& reason) {
    for (const auto& c : counters) {
      if (c.reason() == reason) return c.count();
    }
    return 0;
  }

  void Connect() {
    grpc::ChannelArguments channel_args;
    channel_args.SetMaxReceiveMessageSize(256 << 20);
    channel_ =
        grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), channel_args);
    stub_ = v1::MapService::NewStub(channel_);
  }

  const std::string& address() const { return address_; }
  uint32_t domain() const { return domain_; }
  v1::MapService::Stub& stub() { return *stub_; }
  ChildProcess& process() { return *process_; }

 private:
  uint32_t domain_;
  int port_;
  std::string address_;
  std::unique_ptr<ChildProcess> process_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MapService::Stub> stub_;
};

}  // namespace epmap::testing
