// epmapctl calib ...: the calibration service (samples, jobs, models, transforms).
//   epmapctl calib add-samples FILE.csv [--set NAME]
//   epmapctl calib samples [--set NAME] [--json]
//   epmapctl calib delete-samples --set NAME
//   epmapctl calib start eye-hand --method se3|se3-scale|mixture [--experts K] [--set NAME]
//                        [--outliers reject|keep] [--activate] [--wait] [--json] ...
//   epmapctl calib start stereo-extrinsics [--frames N] [--activate] [--wait] [--json]
//   epmapctl calib jobs [--json] | job ID [--json] | watch ID [--json] | cancel ID
//   epmapctl calib models [--json] | activate MODEL_ID | rollback [--kind KIND]
//   epmapctl calib transform --in FILE.csv --out FILE.csv [--model ID]

#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "clients/epmapctl/client.h"
#include "epmap/v1/calibration_service.grpc.pb.h"
#include "perception/calibration/calibration_error.h"
#include "perception/calibration/eye_hand_samples.h"
#include "services/mapping/api/proto_conversions.h"

namespace {

using epmap::ctl::ClientOptions;
namespace v1 = epmap::v1;

// Samples per AddSamples request (about 70 bytes each on the wire).
constexpr size_t kBatch = 10000;

std::string Json(const google::protobuf::Message& m) {
  std::string text;
  google::protobuf::util::JsonPrintOptions print;
  print.always_print_primitive_fields = true;
  print.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(m, &text, print);
  return text;
}

std::unique_ptr<v1::CalibrationService::Stub> Stub(const ClientOptions& o) {
  return v1::CalibrationService::NewStub(o.Channel());
}

// One unary call of the calibration service, under the options' deadline. A failed call is
// reported (and the exit code set): false.
template <typename Request, typename Response>
bool Call(ClientOptions& o,
          grpc::Status (v1::CalibrationService::Stub::*method)(grpc::ClientContext*, const Request&,
                                                               Response*),
          const Request& request, Response* response) {
  const auto stub = Stub(o);
  const auto context = o.Context();
  const grpc::Status status = ((*stub).*method)(context.get(), request, response);
  if (status.ok()) return true;
  o.exit_code = o.Fail(status);
  return false;
}

std::string Cm(double m) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f cm", 100 * m);
  return buf;
}

// One line per job for people.
std::string Describe(const v1::Job& j) {
  std::ostringstream s;
  s << j.id() << "  " << epmap::mapping::JobKindName(j.kind()) << "  "
    << v1::JobState_Name(j.state());
  if (j.state() == v1::RUNNING) {
    s << " " << static_cast<int>(std::lround(100 * j.progress())) << "% (" << j.stage() << ")";
  }
  if (!j.model_id().empty()) s << "  model " << j.model_id();
  if (!j.message().empty()) s << "  " << j.message();
  return s.str();
}

void PrintModel(const v1::Model& m) {
  std::printf("%s%s  %s\n", m.id().c_str(), m.active() ? " (active)" : "", m.description().c_str());
  const auto& e = m.errors();
  if (m.kind() == v1::EYE_HAND) {
    std::printf("    uncalibrated %s; training mean %s (%u samples)",
                Cm(e.initial_mean_m()).c_str(), Cm(e.train_mean_m()).c_str(), e.train_count());
    if (e.holdout_count() > 0) {
      std::printf("; hold-out mean %s, rmse %s (%u samples)", Cm(e.holdout_mean_m()).c_str(),
                  Cm(e.holdout_rmse_m()).c_str(), e.holdout_count());
    }
    std::printf("; %u outliers rejected\n", e.outliers_rejected());
  } else {
    std::printf(
        "    rotation correction %.3f deg, baseline direction %.3f deg; vertical offset "
        "%.3f px (prior %.3f px); %u frames used, %u refused\n",
        e.prior_rotation_deviation_deg(), e.prior_baseline_deviation_deg(),
        e.median_vertical_offset_px(), e.prior_median_vertical_offset_px(), e.frames_used(),
        e.frames_failed());
  }
}

// Follows a job to its end: a progress bar on stderr (JSON lines with --json), the finished
// job on stdout. Exit code 0 only when it SUCCEEDED.
int Follow(const ClientOptions& o, const std::string& id, bool json) {
  auto stub = Stub(o);
  grpc::ClientContext context;  // no deadline: a job may run for minutes
  v1::WatchJobRequest request;
  request.set_id(id);
  auto reader = stub->WatchJob(&context, request);
  v1::Job job, last;
  const bool tty = ::isatty(2);
  std::string last_stage;
  bool bar_drawn = false;
  while (reader->Read(&job)) {
    last = job;
    if (json) {
      std::cerr << Json(job) << "\n";
    } else if (tty) {
      const int width = 30;
      const int filled =
          static_cast<int>(std::lround(width * std::clamp(job.progress(), 0.0, 1.0)));
      std::fprintf(stderr, "\r[%s%s] %3d%% %-22.22s it %-7llu cost %-10.4g",
                   std::string(static_cast<size_t>(filled), '#').c_str(),
                   std::string(static_cast<size_t>(width - filled), '-').c_str(),
                   static_cast<int>(std::lround(100 * job.progress())), job.stage().c_str(),
                   static_cast<unsigned long long>(job.iteration()), job.cost());
      bar_drawn = true;
    } else if (job.stage() != last_stage) {
      std::fprintf(stderr, "%s: %3d%% %s\n", id.c_str(),
                   static_cast<int>(std::lround(100 * job.progress())), job.stage().c_str());
    }
    last_stage = job.stage();
  }
  if (bar_drawn) std::fprintf(stderr, "\n");
  const grpc::Status status = reader->Finish();
  if (!status.ok()) return o.Fail(status);
  if (json) {
    std::cout << Json(last) << "\n";
  } else {
    std::cout << Describe(last) << "\n";
  }
  if (last.state() != v1::SUCCEEDED) {
    std::cerr << "epmapctl: job " << last.id() << " " << v1::JobState_Name(last.state()) << ": "
              << last.message() << "\n";
    return 1;
  }
  return 0;
}

int Start(const ClientOptions& o, const v1::StartJobRequest& request, bool wait, bool json) {
  auto stub = Stub(o);
  v1::Job job;
  const auto context = o.Context();
  const grpc::Status status = stub->StartJob(context.get(), request, &job);
  if (!status.ok()) return o.Fail(status);
  if (wait) return Follow(o, job.id(), json);
  if (json) {
    std::cout << Json(job) << "\n";
  } else {
    std::cout << job.id() << "\n";
  }
  return 0;
}

// --- CSV of points: a header line, then x,y,z per row ---

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  return out;
}

bool ParsePoint(const std::string& line, v1::Vector3* p) {
  const auto f = SplitCsv(line);
  if (f.size() != 3) return false;
  double v[3];
  for (int i = 0; i < 3; ++i) {
    try {
      size_t used = 0;
      v[i] = std::stod(f[static_cast<size_t>(i)], &used);
      while (used < f[static_cast<size_t>(i)].size() &&
             std::isspace(static_cast<unsigned char>(f[static_cast<size_t>(i)][used])))
        ++used;
      if (used != f[static_cast<size_t>(i)].size()) return false;
    } catch (const std::exception&) {
      return false;
    }
  }
  p->set_x(v[0]);
  p->set_y(v[1]);
  p->set_z(v[2]);
  return true;
}

int Transform(const ClientOptions& o, const std::string& in_path, const std::string& out_path,
              const std::string& model_id) {
  std::ifstream in(in_path);
  if (!in) {
    std::cerr << "epmapctl: cannot open " << in_path << "\n";
    return 2;
  }
  v1::TransformPointsRequest request;
  request.set_model_id(model_id);
  std::string line, header;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_no == 1) {
      header = line;  // the header line is copied to the output
      continue;
    }
    if (line.empty()) continue;
    if (!ParsePoint(line, request.add_points())) {
      std::cerr << "epmapctl: " << in_path << ":" << line_no << ": expected x,y,z, got '" << line
                << "'\n";
      return 2;
    }
  }
  auto stub = Stub(o);
  v1::TransformPointsResponse response;
  const auto context = o.Context();
  const grpc::Status status = stub->TransformPoints(context.get(), request, &response);
  if (!status.ok()) return o.Fail(status);
  std::ofstream out(out_path);
  if (!out) {
    std::cerr << "epmapctl: cannot write " << out_path << "\n";
    return 1;
  }
  out << (header.empty() ? "x,y,z" : header) << "\n";
  char buf[128];
  for (const auto& p : response.points()) {
    std::snprintf(buf, sizeof buf, "%.9g,%.9g,%.9g\n", p.x(), p.y(), p.z());
    out << buf;
  }
  std::cerr << "transformed " << response.points_size() << " points with " << response.model_id()
            << "\n";
  return 0;
}

void Setup(CLI::App& app, ClientOptions& o) {
  auto* calib = app.add_subcommand("calib", "calibration samples, jobs and models");
  calib->require_subcommand(1);

  {
    auto* cmd = calib->add_subcommand("add-samples", "store eye-hand samples from a CSV file");
    auto file = std::make_shared<std::string>();
    auto set = std::make_shared<std::string>("default");
    cmd->add_option("file", *file, "CSV: #timestamp [ns],xa,ya,za,xb,yb,zb,path")->required();
    cmd->add_option("--set", *set, "sample set name")->capture_default_str();
    cmd->callback([&o, file, set] {
      std::vector<epmap::calibration::EyeHandSample> samples;
      try {
        samples = epmap::calibration::ReadEyeHandCsv(*file);
      } catch (const std::exception& e) {
        std::cerr << "epmapctl: " << e.what() << "\n";
        o.exit_code = 2;
        return;
      }
      auto stub = Stub(o);
      uint64_t stored = 0, total = 0;
      for (size_t begin = 0; begin < samples.size(); begin += kBatch) {
        v1::AddSamplesRequest request;
        request.set_set(*set);
        for (size_t i = begin; i < std::min(samples.size(), begin + kBatch); ++i) {
          const auto& s = samples[i];
          epmap::mapping::ToProto(s.stamp_ns, s.xa, s.xb, s.path, request.add_samples());
        }
        v1::AddSamplesResponse response;
        const auto context = o.Context();
        const grpc::Status status = stub->AddSamples(context.get(), request, &response);
        if (!status.ok()) {
          if (stored > 0) std::cerr << "epmapctl: " << stored << " samples were stored before\n";
          o.exit_code = o.Fail(status);
          return;
        }
        stored += response.stored();
        total = response.set_total();
      }
      std::printf("stored %llu samples in set '%s' (%llu in the set)\n",
                  static_cast<unsigned long long>(stored), set->c_str(),
                  static_cast<unsigned long long>(total));
    });
  }
  {
    auto* cmd = calib->add_subcommand("samples", "sample sets and their counts");
    auto set = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    cmd->add_option("--set", *set, "only this set");
    cmd->add_flag("--json", *json, "print as JSON");
    cmd->callback([&o, set, json] {
      v1::ListSamplesRequest request;
      request.set_set(*set);
      v1::ListSamplesResponse response;
      if (!Call(o, &v1::CalibrationService::Stub::ListSamples, request, &response)) return;
      if (*json) {
        std::cout << Json(response) << "\n";
        return;
      }
      std::printf("%llu samples in %d set(s)\n", static_cast<unsigned long long>(response.total()),
                  response.sets_size());
      for (const auto& s : response.sets()) {
        std::printf("  %-32s %8llu samples, %u paths\n", s.name().c_str(),
                    static_cast<unsigned long long>(s.count()), s.paths());
      }
    });
  }
  {
    auto* cmd = calib->add_subcommand("delete-samples", "delete a sample set");
    auto set = std::make_shared<std::string>();
    cmd->add_option("--set", *set, "the set to delete")->required();
    cmd->callback([&o, set] {
      v1::DeleteSamplesRequest request;
      request.set_set(*set);
      v1::DeleteSamplesResponse response;
      if (!Call(o, &v1::CalibrationService::Stub::DeleteSamples, request, &response)) return;
      std::printf("deleted %llu samples\n", static_cast<unsigned long long>(response.deleted()));
    });
  }
  {
    auto* start = calib->add_subcommand("start", "start a calibration job");
    start->require_subcommand(1);
    struct Common {
      bool activate = false, wait = false, json = false;
    };
    const auto add_common = [](CLI::App* cmd, Common& c) {
      cmd->add_flag("--activate", c.activate, "activate the model if the job succeeds");
      cmd->add_flag("--wait", c.wait, "follow the job to its end (exit code 1 unless SUCCEEDED)");
      cmd->add_flag("--json", c.json, "JSON: progress lines on stderr, the job on stdout");
    };
    {
      auto* cmd = start->add_subcommand("eye-hand", "fit the vision-to-kinematics map (Eq. 9, 10)");
      struct Args {
        Common common;
        std::string method, set = "default", outliers = "reject";
        int experts = -1;
        double holdout_share = 0;
        std::vector<std::string> holdout_paths, train_paths;
        bool no_holdout = false;
        uint32_t folds = 0;
        uint64_t seed = 0;
      };
      auto a = std::make_shared<Args>();
      cmd->add_option("--method", a->method, "se3 | se3-scale | mixture")
          ->required()
          ->check(CLI::IsMember({"se3", "se3-scale", "mixture"}));
      cmd->add_option("--experts", a->experts,
                      "mixture: K experts (default 4; 0 = choose K by cross-validation)");
      cmd->add_option("--set", a->set, "sample set")->capture_default_str();
      cmd->add_option("--outliers", a->outliers, "reject | keep")
          ->check(CLI::IsMember({"reject", "keep"}))
          ->capture_default_str();
      cmd->add_option("--holdout-share", a->holdout_share,
                      "share of paths held out (default 0.25)");
      cmd->add_option("--holdout-paths", a->holdout_paths, "paths held out for testing")
          ->delimiter(',');
      cmd->add_option("--train-paths", a->train_paths, "paths to train on")->delimiter(',');
      cmd->add_flag("--no-holdout", a->no_holdout, "train on every path");
      cmd->add_option("--folds", a->folds, "cross-validation folds (default 5)");
      cmd->add_option("--seed", a->seed, "seed of the split and k-means (default 1)");
      add_common(cmd, a->common);
      cmd->callback([&o, a] {
        v1::StartJobRequest request;
        request.set_activate_on_success(a->common.activate);
        auto* spec = request.mutable_spec()->mutable_eye_hand();
        spec->set_method(a->method == "se3"         ? v1::SE3
                         : a->method == "se3-scale" ? v1::SE3_SCALE
                                                    : v1::MIXTURE);
        if (a->method == "mixture") {
          spec->set_experts(static_cast<uint32_t>(a->experts < 0 ? 4 : a->experts));
        } else if (a->experts > 1) {
          std::cerr << "epmapctl: --experts applies to --method mixture only\n";
          o.exit_code = 2;
          return;
        }
        spec->set_set(a->set);
        spec->set_keep_outliers(a->outliers == "keep");
        spec->set_holdout_share(a->holdout_share);
        for (const auto& p : a->holdout_paths) spec->add_holdout_paths(p);
        for (const auto& p : a->train_paths) spec->add_train_paths(p);
        spec->set_no_holdout(a->no_holdout);
        spec->set_folds(a->folds);
        spec->set_seed(a->seed);
        o.exit_code = Start(o, request, a->common.wait, a->common.json);
      });
    }
    {
      auto* cmd = start->add_subcommand(
          "stereo-extrinsics", "self-calibrate the stereo extrinsics on live frames (Sec. III-A)");
      struct Args {
        Common common;
        uint32_t frames = 0, frame_timeout_ms = 0, frame_interval_ms = 0;
        double max_prior_deviation_deg = 0;
      };
      auto a = std::make_shared<Args>();
      cmd->add_option("--frames", a->frames, "live frames to use (default: the service's, 10)");
      cmd->add_option("--max-prior-deviation-deg", a->max_prior_deviation_deg,
                      "accept per-frame results within this of the kinematic prior (default 3)");
      cmd->add_option("--frame-timeout-ms", a->frame_timeout_ms,
                      "fail when no frame comes for this long (default: the service's)");
      cmd->add_option("--frame-interval-ms", a->frame_interval_ms,
                      "use frames at least this far apart (default: the service's)");
      add_common(cmd, a->common);
      cmd->callback([&o, a] {
        v1::StartJobRequest request;
        request.set_activate_on_success(a->common.activate);
        auto* spec = request.mutable_spec()->mutable_stereo_extrinsics();
        spec->set_frames(a->frames);
        spec->set_max_prior_deviation_deg(a->max_prior_deviation_deg);
        spec->set_frame_timeout_ms(a->frame_timeout_ms);
        spec->set_frame_interval_ms(a->frame_interval_ms);
        o.exit_code = Start(o, request, a->common.wait, a->common.json);
      });
    }
  }
  {
    auto* cmd = calib->add_subcommand("jobs", "calibration jobs, newest first");
    auto json = std::make_shared<bool>(false);
    auto limit = std::make_shared<uint32_t>(0);
    cmd->add_flag("--json", *json, "print as JSON");
    cmd->add_option("--limit", *limit, "at most this many (default 100)");
    cmd->callback([&o, json, limit] {
      v1::ListJobsRequest request;
      request.set_limit(*limit);
      v1::ListJobsResponse response;
      if (!Call(o, &v1::CalibrationService::Stub::ListJobs, request, &response)) return;
      if (*json) {
        std::cout << Json(response) << "\n";
        return;
      }
      if (response.jobs_size() == 0) std::printf("no jobs\n");
      for (const auto& j : response.jobs()) std::printf("%s\n", Describe(j).c_str());
    });
  }
  {
    auto* cmd = calib->add_subcommand("job", "one job");
    auto id = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    cmd->add_option("id", *id, "job id")->required();
    cmd->add_flag("--json", *json, "print as JSON");
    cmd->callback([&o, id, json] {
      v1::GetJobRequest request;
      request.set_id(*id);
      v1::Job job;
      if (!Call(o, &v1::CalibrationService::Stub::GetJob, request, &job)) return;
      std::cout << (*json ? Json(job) : Describe(job)) << "\n";
    });
  }
  {
    auto* cmd = calib->add_subcommand("watch", "follow a job to its end");
    auto id = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    cmd->add_option("id", *id, "job id")->required();
    cmd->add_flag("--json", *json, "JSON: progress lines on stderr, the job on stdout");
    cmd->callback([&o, id, json] { o.exit_code = Follow(o, *id, *json); });
  }
  {
    auto* cmd = calib->add_subcommand("cancel", "cancel a queued or running job");
    auto id = std::make_shared<std::string>();
    cmd->add_option("id", *id, "job id")->required();
    cmd->callback([&o, id] {
      v1::CancelJobRequest request;
      request.set_id(*id);
      v1::Job job;
      if (!Call(o, &v1::CalibrationService::Stub::CancelJob, request, &job)) return;
      std::cout << Describe(job) << "\n";
    });
  }
  {
    auto* cmd = calib->add_subcommand("models", "the models jobs yielded, oldest first");
    auto json = std::make_shared<bool>(false);
    auto kind = std::make_shared<std::string>();
    cmd->add_flag("--json", *json, "print as JSON");
    cmd->add_option("--kind", *kind, "eye-hand | stereo-extrinsics (default: both)")
        ->check(CLI::IsMember({"eye-hand", "stereo-extrinsics"}));
    cmd->callback([&o, json, kind] {
      v1::ListModelsRequest request;
      request.set_kind(epmap::mapping::JobKindFromName(*kind));
      v1::ListModelsResponse response;
      if (!Call(o, &v1::CalibrationService::Stub::ListModels, request, &response)) return;
      if (*json) {
        std::cout << Json(response) << "\n";
        return;
      }
      if (response.models_size() == 0) std::printf("no models\n");
      for (const auto& m : response.models()) PrintModel(m);
    });
  }
  {
    auto* cmd = calib->add_subcommand("activate", "make a model the active one of its kind");
    auto id = std::make_shared<std::string>();
    cmd->add_option("model_id", *id, "e.g. eye-hand-2")->required();
    cmd->callback([&o, id] {
      v1::ActivateModelRequest request;
      request.set_id(*id);
      v1::Model model;
      if (!Call(o, &v1::CalibrationService::Stub::ActivateModel, request, &model)) return;
      std::printf("active %s model: %s\n", epmap::mapping::JobKindName(model.kind()),
                  model.id().c_str());
    });
  }
  {
    auto* cmd = calib->add_subcommand("rollback", "re-activate the previously active model");
    auto kind = std::make_shared<std::string>("eye-hand");
    cmd->add_option("--kind", *kind, "eye-hand | stereo-extrinsics")
        ->check(CLI::IsMember({"eye-hand", "stereo-extrinsics"}))
        ->capture_default_str();
    cmd->callback([&o, kind] {
      v1::RollbackModelRequest request;
      request.set_kind(epmap::mapping::JobKindFromName(*kind));
      v1::Model model;
      if (!Call(o, &v1::CalibrationService::Stub::RollbackModel, request, &model)) return;
      if (model.id().empty()) {
        std::printf("rolled back: no %s model is active now\n", kind->c_str());
      } else {
        std::printf("rolled back: active %s model: %s\n", kind->c_str(), model.id().c_str());
      }
    });
  }
  {
    auto* cmd = calib->add_subcommand(
        "transform", "apply the active (or a named) eye-hand model to points of the vision frame");
    auto in = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto model = std::make_shared<std::string>();
    cmd->add_option("--in", *in, "CSV: a header line, then x,y,z per row [m]")->required();
    cmd->add_option("--out", *out, "CSV written: the same header, corrected x,y,z")->required();
    cmd->add_option("--model", *model, "model id (default: the active eye-hand model)");
    cmd->callback([&o, in, out, model] { o.exit_code = Transform(o, *in, *out, *model); });
  }
}

}  // namespace

EPMAP_CTL_COMMAND(calib, Setup);
