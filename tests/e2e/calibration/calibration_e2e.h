#pragma once
// What the calibration end-to-end tests share: a CalibrationService stub to a real epmapd,
// the sim's eye-hand samples as protos, waiting for a job, and running epmapctl with stdout and
// stderr kept apart.

#include <epmap/v1/calibration_service.grpc.pb.h>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "clients/sim/scenario.h"
#include "services/mapping/api/proto_conversions.h"
#include "tests/support/epmapd_fixture.h"

namespace epmap::testing {

inline std::unique_ptr<v1::CalibrationService::Stub> CalibrationStub(const std::string& address) {
  return v1::CalibrationService::NewStub(
      grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
}

inline std::unique_ptr<grpc::ClientContext> Deadline(int seconds = 10) {
  auto c = std::make_unique<grpc::ClientContext>();
  c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return c;
}

// The sim's eye-hand scenario (2000 samples on 20 paths) as AddSamples samples.
inline std::vector<v1::EyeHandSample> SimEyeHandSamples(uint64_t seed = 1) {
  std::vector<v1::EyeHandSample> out;
  for (const auto& s : sim::MakeScenario({.name = "eye-hand", .seed = seed})->EyeHandSamples()) {
    mapping::ToProto(s.stamp_ns, s.xa, s.xb, s.path, &out.emplace_back());
  }
  return out;
}

inline grpc::Status AddSamples(v1::CalibrationService::Stub& stub, const std::string& set,
                               const std::vector<v1::EyeHandSample>& samples,
                               v1::AddSamplesResponse* response = nullptr) {
  v1::AddSamplesRequest request;
  request.set_set(set);
  for (const auto& s : samples) *request.add_samples() = s;
  v1::AddSamplesResponse ignored;
  return stub.AddSamples(Deadline().get(), request, response ? response : &ignored);
}

inline bool Finished(v1::JobState s) {
  return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED || s == v1::INTERRUPTED;
}

// Polls GetJob until `done` holds for the job or the time runs out; returns the last seen.
template <class Predicate>
v1::Job WaitJob(v1::CalibrationService::Stub& stub, const std::string& id, Predicate done,
                std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  v1::Job job;
  while (std::chrono::steady_clock::now() < deadline) {
    v1::GetJobRequest request;
    request.set_id(id);
    job.Clear();
    if (stub.GetJob(Deadline().get(), request, &job).ok() && done(job)) return job;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return job;
}

inline std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct CliResult {
  int exit_code = -1;
  std::string out, err;
  // The last line of stdout (JSON printers write one object per line).
  std::string LastLine() const {
    std::istringstream s(out);
    std::string line, last;
    while (std::getline(s, line)) {
      if (!line.empty()) last = line;
    }
    return last;
  }
};

// Runs build/bin/<binary> with `args`, stdout and stderr captured separately.
inline CliResult RunBinary(const std::string& binary, const std::vector<std::string>& args,
                           const std::filesystem::path& work_dir) {
  static int counter = 0;
  const auto err_path = work_dir / ("stderr-" + std::to_string(counter++) + ".txt");
  std::string command = ShellQuote((BinDir() / binary).string());
  for (const auto& a : args) {
    command += ' ';
    command += ShellQuote(a);
  }
  command += " 2>";  // (one append at a time: GCC 12 warns falsely on "..." + std::string&&)
  command += ShellQuote(err_path.string());
  CliResult r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(err_path);
  std::stringstream ss;
  ss << err.rdbuf();
  r.err = ss.str();
  return r;
}

template <class M>
bool ParseJson(const std::string& json, M* message) {
  return google::protobuf::util::JsonStringToMessage(json, message).ok();
}

}  // namespace epmap::testing
