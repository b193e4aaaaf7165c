// epmap-bench calib-service [--samples FILE.csv] [--runs N] [--vergence] [--frames N]
//                           [--direction-prior-deg X]
// The calibration service measured from a client: a real epmapd with a state folder, samples
// added over gRPC, and calibration jobs timed from StartJob until the client sees SUCCEEDED on
// its WatchJob stream.
//
// Cases (one JSON line each):
//   eye-hand-job   a 4-expert mixture job end to end (median of --runs), beside the same
//                  CalibrateEyeHand call in this process on the same split (the baseline), and
//                  the two results compared.
//   vergence-job   (--vergence) epmap-sim publish --scenario vergence feeds epmapd; a
//                  stereo-extrinsics job on N live frames; its model checked against the sim's
//                  true extrinsics on 30 frames spread over the sequence (rotation, baseline
//                  direction, median vertical offset of SIFT matches after rectification),
//                  beside the kinematic prior alone, the true extrinsics, and a single-frame
//                  self-calibration on each evaluation frame.

#include <epmap/v1/calibration_service.grpc.pb.h>
#include <epmap/v1/map_service.grpc.pb.h>
#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "bench/epmap_bench/command_registry.h"
#include "bench/epmap_bench/summary.h"
#include "clients/sim/scenario.h"
#include "common/process/child_process.h"
#include "perception/calibration/dataset_intrinsics.h"
#include "perception/calibration/eye_hand_calibration.h"
#include "perception/calibration/stereo_self_calibration.h"
#include "services/mapping/api/proto_conversions.h"
#include "services/mapping/calibration/stereo_correction.h"

namespace {

namespace fs = std::filesystem;
namespace v1 = epmap::v1;
using namespace epmap::calibration;
using Clock = std::chrono::steady_clock;
using namespace epmap::bench;

std::unique_ptr<grpc::ClientContext> Deadline(int seconds = 30) {
  auto c = std::make_unique<grpc::ClientContext>();
  c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return c;
}

// A real epmapd on a free port with its own state folder.
class Service {
 public:
  Service(const fs::path& work, uint32_t domain, std::vector<std::string> extra)
      : address_("127.0.0.1:" + std::to_string(epmap::process::FreeTcpPort())) {
    fs::create_directories(work);
    const fs::path bin = fs::canonical("/proc/self/exe").parent_path();
    std::vector<std::string> args = {"--listen",    address_,
                                     "--domain",    std::to_string(domain),
                                     "--state-dir", (work / "state").string(),
                                     "--log-level", "warn"};
    args.insert(args.end(), extra.begin(), extra.end());
    process_ =
        std::make_unique<epmap::process::ChildProcess>(bin / "epmapd", args, work / "epmapd.log");
    const auto deadline = Clock::now() + std::chrono::seconds(30);
    while (Clock::now() < deadline) {
      if (!process_->running()) break;
      // A fresh channel per attempt: one that failed during start-up backs off for seconds.
      auto channel = grpc::CreateChannel(address_, grpc::InsecureChannelCredentials());
      v1::ServiceStatus status;
      if (v1::MapService::NewStub(channel)->GetStatus(Deadline(2).get(), {}, &status).ok()) {
        stub_ = v1::CalibrationService::NewStub(channel);
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    throw std::runtime_error("epmapd did not start: " + process_->Output());
  }
  ~Service() {
    process_->Signal(SIGTERM);
    process_->Wait(std::chrono::seconds(10));
  }
  v1::CalibrationService::Stub& stub() { return *stub_; }

  // StartJob, then the WatchJob stream until the job ends; *elapsed_ms from before StartJob to
  // the message that reports the end.
  v1::Job RunJob(const v1::StartJobRequest& request, double* elapsed_ms) {
    const auto t0 = Clock::now();
    v1::Job job;
    const auto status = stub_->StartJob(Deadline().get(), request, &job);
    if (!status.ok()) throw std::runtime_error("StartJob: " + status.error_message());
    grpc::ClientContext context;
    v1::WatchJobRequest watch;
    watch.set_id(job.id());
    auto reader = stub_->WatchJob(&context, watch);
    while (reader->Read(&job)) {
      if (job.state() == v1::SUCCEEDED || job.state() == v1::FAILED ||
          job.state() == v1::CANCELLED || job.state() == v1::INTERRUPTED) {
        break;
      }
    }
    *elapsed_ms = MsSince(t0);
    context.TryCancel();
    reader->Finish();
    return job;
  }

 private:
  std::string address_;
  std::unique_ptr<epmap::process::ChildProcess> process_;
  std::unique_ptr<v1::CalibrationService::Stub> stub_;
};

// ---------------------------------------------------------------------------------------------

int RunEyeHand(const std::string& csv, int runs, const fs::path& work, uint32_t domain) {
  std::vector<EyeHandSample> samples;
  if (csv.empty()) {
    for (const auto& s : epmap::sim::MakeScenario({.name = "eye-hand"})->EyeHandSamples()) {
      samples.push_back({s.stamp_ns, s.xa, s.xb, s.path});
    }
  } else {
    samples = ReadEyeHandCsv(csv);
  }
  Service service(work / "eye-hand", domain, {});
  v1::AddSamplesRequest add;
  add.set_set("bench");
  for (const auto& s : samples) {
    epmap::mapping::ToProto(s.stamp_ns, s.xa, s.xb, s.path, add.add_samples());
  }
  const auto t_add = Clock::now();
  v1::AddSamplesResponse added;
  const auto status = service.stub().AddSamples(Deadline().get(), add, &added);
  const double add_ms = MsSince(t_add);
  if (!status.ok()) throw std::runtime_error("AddSamples: " + status.error_message());

  v1::StartJobRequest start;
  auto* spec = start.mutable_spec()->mutable_eye_hand();
  spec->set_method(v1::MIXTURE);
  spec->set_experts(4);
  spec->set_set("bench");
  spec->set_holdout_share(0.25);
  spec->set_seed(1);
  std::vector<double> end_to_end, server_ms, queued_ms;
  v1::Job job;
  for (int r = 0; r < runs; ++r) {
    double ms = 0;
    job = service.RunJob(start, &ms);
    if (job.state() != v1::SUCCEEDED) throw std::runtime_error("job failed: " + job.message());
    end_to_end.push_back(ms);
    server_ms.push_back(static_cast<double>(job.finished_ns() - job.started_ns()) / 1e6);
    queued_ms.push_back(static_cast<double>(job.started_ns() - job.created_ns()) / 1e6);
  }

  // Baseline: the same call in this process on the same split.
  const PathSplit split = SplitByPaths(samples, 0.25, 1);
  EyeHandCalibrationParams params;
  params.method = EyeHandMethod::kMixture;
  params.mixture.experts = 4;
  params.mixture.seed = 1;
  std::vector<double> in_process;
  EyeHandCalibrationResult local;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    local = CalibrateEyeHand(split.train, split.test, params);
    in_process.push_back(MsSince(t0));
  }
  const auto& e = job.errors();
  std::printf(
      "{\"command\":\"calib-service\",\"case\":\"eye-hand-job\",\"samples\":%zu,\"runs\":%d,"
      "\"add_samples_ms\":%s,\"start_to_succeeded_ms\":%s,\"server_job_ms_median\":%s,"
      "\"queued_ms_median\":%s,\"in_process_calibrate_ms\":%s,\"ratio_end_to_end_to_in_process\":%"
      "s,"
      "\"service\":{\"experts\":%u,\"initial_mean_m\":%s,\"train_mean_m\":%s,"
      "\"holdout_mean_m\":%s,\"holdout_count\":%u},"
      "\"in_process\":{\"holdout_mean_m\":%s,\"holdout_count\":%zu},"
      "\"same_result\":%s}\n",
      samples.size(), runs, JsonNumber(add_ms, 4).c_str(), JsonMedianMax(end_to_end).c_str(),
      JsonNumber(Median(server_ms), 4).c_str(), JsonNumber(Median(queued_ms), 4).c_str(),
      JsonMedianMax(in_process).c_str(),
      JsonNumber(Median(end_to_end) / Median(in_process), 3).c_str(), e.experts(),
      JsonNumber(e.initial_mean_m(), 5).c_str(), JsonNumber(e.train_mean_m(), 5).c_str(),
      JsonNumber(e.holdout_mean_m(), 5).c_str(), e.holdout_count(),
      JsonNumber(local.errors.test.mean_m, 5).c_str(), local.errors.test.count,
      std::abs(e.holdout_mean_m() - local.errors.test.mean_m) < 1e-12 ? "true" : "false");
  return 0;
}

// ---------------------------------------------------------------------------------------------

struct VergenceRun {
  v1::Job job;
  double job_ms = 0;
  epmap::mapping::StereoCorrectionModel model;
};

VergenceRun RunVergenceJob(const fs::path& work, uint32_t domain, int frames,
                           const std::string& urdf_path, double direction_prior_deg) {
  std::vector<std::string> extra = {"--urdf", urdf_path};
  fs::create_directories(work);
  if (direction_prior_deg > 0) {
    std::ofstream config(work / "epmapd.yaml");
    config << "calibration:\n  baseline_direction_prior_sigma_deg: " << direction_prior_deg << "\n";
    extra.push_back("--config");
    extra.push_back((work / "epmapd.yaml").string());
  }
  Service service(work, domain, extra);
  const fs::path bin = fs::canonical("/proc/self/exe").parent_path();
  epmap::process::ChildProcess publisher(
      bin / "epmap-sim", {"publish", "--scenario", "vergence", "--domain", std::to_string(domain)},
      work / "sim.log");
  v1::StartJobRequest start;
  start.mutable_spec()->mutable_stereo_extrinsics()->set_frames(static_cast<uint32_t>(frames));
  VergenceRun run;
  run.job = service.RunJob(start, &run.job_ms);
  if (run.job.state() != v1::SUCCEEDED) {
    throw std::runtime_error("stereo job " + v1::JobState_Name(run.job.state()) + ": " +
                             run.job.message());
  }
  v1::ListModelsResponse models;
  service.stub().ListModels(Deadline().get(), {}, &models);
  for (const auto& m : models.models()) {
    if (m.id() == run.job.model_id()) {
      run.model = epmap::mapping::StereoCorrectionModel::FromJson(m.parameters_json());
    }
  }
  publisher.Signal(SIGINT);
  publisher.Wait(std::chrono::seconds(10));
  return run;
}

int RunVergence(int frames, double direction_prior_deg, const fs::path& work, uint32_t domain) {
  const auto scenario = epmap::sim::MakeScenario({.name = "vergence"});
  // The shipped URDF (the nominal chain); the encoders are biased against it.
  const fs::path urdf = work / "icub_head.urdf";
  std::ofstream(urdf) << scenario->urdf();
  const auto chain = epmap::kinematics::UrdfChain::FromFile(urdf);
  const auto names = scenario->joint_names();
  const CameraIntrinsics c0 = IntrinsicsOf(scenario->cam0()), c1 = IntrinsicsOf(scenario->cam1());

  std::vector<std::pair<std::string, VergenceRun>> runs;
  runs.emplace_back("data_only",
                    RunVergenceJob(work / "data-only", domain, frames, urdf.string(), 0.0));
  if (direction_prior_deg > 0) {
    runs.emplace_back("with_direction_prior",
                      RunVergenceJob(work / "with-prior", domain + 1, frames, urdf.string(),
                                     direction_prior_deg));
  }

  // Evaluation frames spread over the whole sequence (the jobs used its first seconds).
  struct Evaluation {
    std::vector<double> rotation, direction, offset;
  };
  std::map<std::string, Evaluation> eval;
  std::vector<double> prior_rotation, prior_direction, prior_offset, truth_offset;
  Evaluation single;  // single-frame self-calibration on each evaluation frame
  std::map<std::string, int> single_failures;
  for (int index = 5; index < scenario->frame_count(); index += 10) {
    const auto f = scenario->RenderSensors(index);
    std::vector<double> joints;
    for (const auto& n : chain.joint_names()) {
      joints.push_back(
          f.joints[static_cast<size_t>(std::find(names.begin(), names.end(), n) - names.begin())]);
    }
    const Eigen::Isometry3d prior = KinematicPrior(chain, joints);
    const Eigen::Isometry3d& truth = f.gt_T_cam0_cam1;
    for (const auto& [name, run] : runs) {
      const Eigen::Isometry3d T = run.model.Apply(prior);
      auto& e = eval[name];
      e.rotation.push_back(RotationAngleDeg(T.linear(), truth.linear()));
      e.direction.push_back(DirectionAngleDeg(T.translation(), truth.translation()));
      e.offset.push_back(MedianRowOffset(c0, c1, T, f.left, f.right));
    }
    prior_rotation.push_back(RotationAngleDeg(prior.linear(), truth.linear()));
    prior_direction.push_back(DirectionAngleDeg(prior.translation(), truth.translation()));
    prior_offset.push_back(MedianRowOffset(c0, c1, prior, f.left, f.right));
    truth_offset.push_back(MedianRowOffset(c0, c1, truth, f.left, f.right));
    try {
      StereoView view{f.left, f.right, prior, f.stamp_ns};
      const auto r = SelfCalibrateStereo(c0, c1, {view});
      single.rotation.push_back(RotationAngleDeg(r.model.T_cam0_cam1.linear(), truth.linear()));
      single.direction.push_back(
          DirectionAngleDeg(r.model.T_cam0_cam1.translation(), truth.translation()));
    } catch (const CalibrationError& e) {
      ++single_failures[ToString(e.code())];
    }
  }
  std::string failures = "{";
  for (const auto& [k, v] : single_failures) {
    failures += (failures.size() > 1 ? "," : "") + JsonQuote(k) + ":" + std::to_string(v);
  }
  failures += "}";
  std::string line = "{\"command\":\"calib-service\",\"case\":\"vergence-job\",\"job_frames\":" +
                     std::to_string(frames) +
                     ",\"evaluation_frames\":" + std::to_string(prior_rotation.size());
  for (const auto& [name, run] : runs) {
    const auto& e = eval[name];
    const auto& je = run.job.errors();
    line += ",\"" + name + "\":{\"direction_prior_sigma_deg\":" +
            JsonNumber(run.model.baseline_direction_prior_sigma_deg, 5) +
            ",\"start_to_succeeded_s\":" + JsonNumber(run.job_ms / 1000, 4) +
            ",\"job_frames_used\":" + std::to_string(je.frames_used()) +
            ",\"job_frames_refused\":" + std::to_string(je.frames_failed()) +
            ",\"correction_deg\":" + JsonNumber(je.prior_rotation_deviation_deg(), 4) +
            ",\"correction_spread_deg\":" + JsonNumber(je.correction_spread_deg(), 3) +
            ",\"job_vertical_offset_px\":" + JsonNumber(je.median_vertical_offset_px(), 4) +
            ",\"rotation_error_deg\":" + JsonMedianMax(e.rotation) +
            ",\"baseline_direction_error_deg\":" + JsonMedianMax(e.direction) +
            ",\"vertical_offset_px\":" + JsonMedianMax(e.offset) + "}";
  }
  line += ",\"kinematic_prior\":{\"rotation_error_deg\":" + JsonMedianMax(prior_rotation) +
          ",\"baseline_direction_error_deg\":" + JsonMedianMax(prior_direction) +
          ",\"vertical_offset_px\":" + JsonMedianMax(prior_offset) + "}";
  line += ",\"true_extrinsics\":{\"vertical_offset_px\":" + JsonMedianMax(truth_offset) + "}";
  line += ",\"single_frame_self_calibration\":{\"rotation_error_deg\":" +
          JsonMedianMax(single.rotation) +
          ",\"baseline_direction_error_deg\":" + JsonMedianMax(single.direction) +
          ",\"failures\":" + failures + "}}";
  std::printf("%s\n", line.c_str());
  return 0;
}

int Run(int argc, char** argv) {
  CLI::App app("the calibration service end to end: jobs over gRPC on a real epmapd", argv[0]);
  std::string samples;
  int runs = 9, frames = 10;
  bool vergence = false, skip_eye_hand = false;
  double direction_prior_deg = 0.5;
  uint32_t domain = 150;
  app.add_option("--samples", samples,
                 "eye-hand samples CSV (default: the sim's eye-hand scenario, 2000 samples)");
  app.add_option("--runs", runs, "eye-hand jobs timed (default 9)");
  app.add_flag("--vergence", vergence, "also the stereo-extrinsics job on the vergence stream");
  app.add_flag("--skip-eye-hand", skip_eye_hand, "only the vergence case");
  app.add_option("--frames", frames, "frames of the stereo-extrinsics job (default 10)");
  app.add_option("--direction-prior-deg", direction_prior_deg,
                 "vergence: also run with calibration.baseline_direction_prior_sigma_deg set to "
                 "this (default 0.5; 0 = skip)");
  app.add_option("--domain", domain, "DDS domain (default 150; the vergence case uses two)");
  CLI11_PARSE(app, argc, argv);
  const fs::path work =
      fs::temp_directory_path() / ("epmap-bench-calib-service-" + std::to_string(::getpid()));
  fs::create_directories(work);
  int rc = 0;
  try {
    if (!skip_eye_hand) rc |= RunEyeHand(samples, std::max(1, runs), work, domain);
    if (vergence) rc |= RunVergence(frames, direction_prior_deg, work, domain + 2);
  } catch (const std::exception& e) {
    std::cerr << "epmap-bench calib-service: " << e.what() << " (logs in " << work << ")\n";
    return 1;
  }
  fs::remove_all(work);
  return rc;
}

}  // namespace

EPMAP_BENCH_COMMAND(calib_service, "calib-service",
                    "calibration jobs end to end over gRPC on a real epmapd (eye-hand, vergence)",
                    Run);
