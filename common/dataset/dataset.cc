#include "common/dataset/dataset.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "common/imaging/pfm.h"

namespace epmap::dataset {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void Fail(const fs::path& file, const std::string& what) {
  throw std::runtime_error(file.string() + ": " + what);
}

// EuRoC writes "%YAML:1.0" (OpenCV's dialect) which yaml-cpp rejects; drop that line.
YAML::Node LoadYaml(const fs::path& file) {
  std::ifstream in(file);
  if (!in) Fail(file, "cannot open");
  std::stringstream text;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (first && line.rfind("%YAML", 0) == 0) {
      first = false;
      continue;
    }
    first = false;
    text << line << '\n';
  }
  try {
    return YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    Fail(file, std::string("YAML error: ") + e.what());
  }
}

// Splits one CSV line on commas, trimming blanks.
std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::stringstream ss(line);
  while (std::getline(ss, field, ',')) {
    const auto b = field.find_first_not_of(" \t\r");
    const auto e = field.find_last_not_of(" \t\r");
    fields.push_back(b == std::string::npos ? "" : field.substr(b, e - b + 1));
  }
  return fields;
}

// Reads a CSV whose first line (starting with '#') is a header; returns the data rows.
std::vector<std::vector<std::string>> ReadCsv(const fs::path& file,
                                              std::vector<std::string>* header = nullptr) {
  std::ifstream in(file);
  if (!in) Fail(file, "cannot open");
  std::vector<std::vector<std::string>> rows;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == '#' ||
        (first && !std::isdigit(static_cast<unsigned char>(line[0])) && line[0] != '-')) {
      if (first && header) *header = SplitCsv(line[0] == '#' ? line.substr(1) : line);
      first = false;
      continue;
    }
    first = false;
    rows.push_back(SplitCsv(line));
  }
  return rows;
}

int64_t ParseStamp(const fs::path& file, const std::string& s) {
  try {
    size_t used = 0;
    const long long v = std::stoll(s, &used);
    if (used != s.size()) Fail(file, "bad timestamp '" + s + "'");
    return v;
  } catch (const std::logic_error&) {
    Fail(file, "bad timestamp '" + s + "'");
  }
}

double ParseDouble(const fs::path& file, const std::string& s) {
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size()) Fail(file, "bad number '" + s + "'");
    return v;
  } catch (const std::logic_error&) {
    Fail(file, "bad number '" + s + "'");
  }
}

std::map<int64_t, fs::path> ReadImageIndex(const fs::path& folder) {
  std::map<int64_t, fs::path> index;
  const fs::path csv = folder / "data.csv";
  for (const auto& row : ReadCsv(csv)) {
    if (row.size() < 2) Fail(csv, "expected 'timestamp,filename' rows");
    index[ParseStamp(csv, row[0])] = folder / "data" / row[1];
  }
  return index;
}

std::vector<PlanarPose> ReadPlanar(const fs::path& csv) {
  std::vector<PlanarPose> poses;
  for (const auto& row : ReadCsv(csv)) {
    if (row.size() < 4) Fail(csv, "expected 'timestamp,x,y,theta' rows");
    poses.push_back({ParseStamp(csv, row[0]), ParseDouble(csv, row[1]), ParseDouble(csv, row[2]),
                     ParseDouble(csv, row[3])});
  }
  std::sort(poses.begin(), poses.end(),
            [](const PlanarPose& a, const PlanarPose& b) { return a.stamp_ns < b.stamp_ns; });
  return poses;
}

Dataset LoadSequence(const fs::path& root) {
  Dataset d;
  d.kind = Dataset::Kind::kSequence;
  d.root = root;
  const fs::path mav0 = root / "mav0";
  d.cam0 = ReadCameraSensor(mav0 / "cam0" / "sensor.yaml");
  d.cam1 = ReadCameraSensor(mav0 / "cam1" / "sensor.yaml");
  const auto left = ReadImageIndex(mav0 / "cam0");
  const auto right = ReadImageIndex(mav0 / "cam1");
  for (const auto& [stamp, path] : left) {
    auto it = right.find(stamp);
    if (it != right.end()) d.frames.push_back({stamp, path, it->second});
  }
  if (d.frames.empty()) Fail(mav0, "no stereo frame: cam0 and cam1 share no timestamp");

  const fs::path joints_dir = mav0 / "joints0";
  if (fs::exists(joints_dir / "data.csv")) {
    std::vector<std::string> header;
    const auto rows = ReadCsv(joints_dir / "data.csv", &header);
    if (fs::exists(joints_dir / "sensor.yaml")) {
      const YAML::Node y = LoadYaml(joints_dir / "sensor.yaml");
      if (y["names"]) d.joint_names = y["names"].as<std::vector<std::string>>();
    }
    if (d.joint_names.empty() && header.size() > 1) {
      // Header "timestamp [ns],name1,name2,...": the names are the columns.
      d.joint_names.assign(header.begin() + 1, header.end());
    }
    for (const auto& row : rows) {
      if (row.size() != d.joint_names.size() + 1) {
        Fail(joints_dir / "data.csv", "row has " + std::to_string(row.size()) +
                                          " fields, expected 1 + " +
                                          std::to_string(d.joint_names.size()) + " joints");
      }
      JointSample s;
      s.stamp_ns = ParseStamp(joints_dir / "data.csv", row[0]);
      for (size_t i = 1; i < row.size(); ++i) {
        s.positions.push_back(ParseDouble(joints_dir / "data.csv", row[i]));
      }
      d.joints.push_back(std::move(s));
    }
    std::sort(d.joints.begin(), d.joints.end(),
              [](const JointSample& a, const JointSample& b) { return a.stamp_ns < b.stamp_ns; });
  }
  if (fs::exists(mav0 / "odometry0" / "data.csv")) {
    d.odometry = ReadPlanar(mav0 / "odometry0" / "data.csv");
  }
  if (fs::exists(mav0 / "kinematics.urdf")) d.urdf = mav0 / "kinematics.urdf";

  if (fs::exists(mav0 / "gt_camera_pose0" / "data.csv")) {
    const fs::path csv = mav0 / "gt_camera_pose0" / "data.csv";
    for (const auto& row : ReadCsv(csv)) {
      if (row.size() < 8) Fail(csv, "expected 'timestamp,px,py,pz,qw,qx,qy,qz' rows");
      PoseSample p;
      p.stamp_ns = ParseStamp(csv, row[0]);
      const Eigen::Vector3d t(ParseDouble(csv, row[1]), ParseDouble(csv, row[2]),
                              ParseDouble(csv, row[3]));
      Eigen::Quaterniond q(ParseDouble(csv, row[4]), ParseDouble(csv, row[5]),
                           ParseDouble(csv, row[6]), ParseDouble(csv, row[7]));
      p.pose = Eigen::Isometry3d::Identity();
      p.pose.linear() = q.normalized().toRotationMatrix();
      p.pose.translation() = t;
      d.gt_camera_pose.push_back(p);
    }
  }
  if (fs::exists(mav0 / "gt_base_pose0" / "data.csv")) {
    d.gt_base_pose = ReadPlanar(mav0 / "gt_base_pose0" / "data.csv");
  }
  if (fs::exists(mav0 / "gt_disparity0" / "data.csv")) {
    d.gt_disparity = ReadImageIndex(mav0 / "gt_disparity0");
  }
  if (fs::exists(mav0 / "gt_unexpected0" / "data.csv")) {
    d.gt_unexpected = ReadImageIndex(mav0 / "gt_unexpected0");
  }
  if (fs::exists(mav0 / "gt_movers0" / "data.csv")) {
    const fs::path csv = mav0 / "gt_movers0" / "data.csv";
    for (const auto& row : ReadCsv(csv)) {
      if (row.size() < 5) Fail(csv, "expected 'timestamp,id,x,y,z' rows");
      d.gt_movers.push_back({ParseStamp(csv, row[0]), static_cast<int>(ParseDouble(csv, row[1])),
                             Eigen::Vector3d(ParseDouble(csv, row[2]), ParseDouble(csv, row[3]),
                                             ParseDouble(csv, row[4]))});
    }
    std::stable_sort(
        d.gt_movers.begin(), d.gt_movers.end(),
        [](const MoverSample& a, const MoverSample& b) { return a.stamp_ns < b.stamp_ns; });
  }
  if (fs::exists(mav0 / "gt_map" / "walls.csv")) {
    const fs::path csv = mav0 / "gt_map" / "walls.csv";
    for (const auto& row : ReadCsv(csv)) {
      if (row.size() < 4) Fail(csv, "expected 'x1,y1,x2,y2' rows");
      d.walls.push_back({ParseDouble(csv, row[0]), ParseDouble(csv, row[1]),
                         ParseDouble(csv, row[2]), ParseDouble(csv, row[3])});
    }
  }
  return d;
}

Dataset LoadPair(const fs::path& root) {
  Dataset d;
  d.kind = Dataset::Kind::kStereoPair;
  d.root = root;
  const YAML::Node y = LoadYaml(root / "pair.yaml");
  const cv::Mat left = cv::imread((root / "left.png").string(), cv::IMREAD_UNCHANGED);
  if (left.empty()) Fail(root / "left.png", "cannot read image");
  // A pair is one already-rectified frame; focal length and baseline are optional in pair.yaml
  // (disparity needs neither; depth does).
  const double f = y["fx"] ? y["fx"].as<double>() : 0.8 * left.cols;
  const double baseline = y["baseline"] ? y["baseline"].as<double>() : 0.1;
  for (CameraSensor* cam : {&d.cam0, &d.cam1}) {
    cam->width = left.cols;
    cam->height = left.rows;
    cam->fu = cam->fv = f;
    cam->cu = y["cx"] ? y["cx"].as<double>() : (left.cols - 1) / 2.0;
    cam->cv = y["cy"] ? y["cy"].as<double>() : (left.rows - 1) / 2.0;
    cam->distortion = {0, 0, 0, 0};
  }
  d.cam1.T_BS(0, 3) = baseline;
  constexpr int64_t kStamp = 1'000'000'000;  // one frame at t = 1 s
  d.frames.push_back({kStamp, root / "left.png", root / "right.png"});
  if (y["gt_scale"]) d.gt_scale = y["gt_scale"].as<double>();
  if (y["min_disparity"]) d.min_disparity = y["min_disparity"].as<int>();
  if (y["num_disparities"]) d.num_disparities = y["num_disparities"].as<int>();
  if (y["gt_disparity"]) {
    const auto name = y["gt_disparity"].as<std::string>();
    if (name != "none" && fs::exists(root / name)) d.gt_disparity[kStamp] = root / name;
  }
  return d;
}

}  // namespace

CameraSensor ReadCameraSensor(const fs::path& sensor_yaml) {
  const YAML::Node y = LoadYaml(sensor_yaml);
  CameraSensor cam;
  try {
    const auto res = y["resolution"].as<std::vector<int>>();
    const auto k = y["intrinsics"].as<std::vector<double>>();
    if (res.size() != 2 || k.size() != 4) Fail(sensor_yaml, "resolution or intrinsics malformed");
    cam.width = res[0];
    cam.height = res[1];
    cam.fu = k[0];
    cam.fv = k[1];
    cam.cu = k[2];
    cam.cv = k[3];
    if (y["distortion_model"]) cam.distortion_model = y["distortion_model"].as<std::string>();
    if (y["distortion_coefficients"]) {
      cam.distortion = y["distortion_coefficients"].as<std::vector<double>>();
    }
    if (y["rate_hz"]) cam.rate_hz = y["rate_hz"].as<double>();
    if (y["T_BS"]) {
      const auto data = y["T_BS"]["data"].as<std::vector<double>>();
      if (data.size() != 16) Fail(sensor_yaml, "T_BS.data must have 16 values");
      for (int i = 0; i < 16; ++i) cam.T_BS(i / 4, i % 4) = data[static_cast<size_t>(i)];
    }
  } catch (const YAML::Exception& e) {
    Fail(sensor_yaml, std::string("missing or malformed field: ") + e.what());
  }
  if (cam.width <= 0 || cam.height <= 0 || cam.fu <= 0 || cam.fv <= 0) {
    Fail(sensor_yaml, "resolution and focal lengths must be positive");
  }
  return cam;
}

Dataset Load(const fs::path& path) {
  if (!fs::exists(path)) throw std::runtime_error(path.string() + ": no such dataset");
  if (fs::exists(path / "pair.yaml")) return LoadPair(path);
  if (fs::exists(path / "mav0")) return LoadSequence(path);
  if (path.filename() == "mav0" && fs::exists(path / "cam0"))
    return LoadSequence(path.parent_path());
  throw std::runtime_error(path.string() +
                           ": neither a sequence (mav0/cam0, mav0/cam1) nor a stereo pair "
                           "(left.png, right.png, pair.yaml)");
}

bool Dataset::rectified() const {
  const auto zero = [](const std::vector<double>& d) {
    return std::all_of(d.begin(), d.end(), [](double v) { return v == 0.0; });
  };
  const Eigen::Matrix4d rel = cam0.T_BS.inverse() * cam1.T_BS;
  const bool same_k =
      cam0.fu == cam1.fu && cam0.fv == cam1.fv && cam0.cu == cam1.cu && cam0.cv == cam1.cv;
  const bool pure_x = (rel.block<3, 3>(0, 0) - Eigen::Matrix3d::Identity()).norm() < 1e-9 &&
                      std::abs(rel(1, 3)) < 1e-9 && std::abs(rel(2, 3)) < 1e-9;
  return zero(cam0.distortion) && zero(cam1.distortion) && same_k && pure_x;
}

double Dataset::baseline_m() const {
  const Eigen::Matrix4d rel = cam0.T_BS.inverse() * cam1.T_BS;
  return rel.block<3, 1>(0, 3).norm();
}

cv::Mat LoadGtDisparity(const Dataset& dataset, int64_t stamp_ns) {
  const auto it = dataset.gt_disparity.find(stamp_ns);
  if (it == dataset.gt_disparity.end()) return {};
  if (it->second.extension() == ".pfm") {
    cv::Mat d = imaging::ReadPfm(it->second);
    d.setTo(std::numeric_limits<float>::quiet_NaN(), d <= 0.0F);
    return d;
  }
  const cv::Mat raw = cv::imread(it->second.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (raw.empty()) throw std::runtime_error(it->second.string() + ": cannot read image");
  cv::Mat d;
  raw.convertTo(d, CV_32F, 1.0 / dataset.gt_scale);
  d.setTo(std::numeric_limits<float>::quiet_NaN(), raw == 0);
  return d;
}

cv::Mat LoadGtUnexpected(const Dataset& dataset, int64_t stamp_ns) {
  const auto it = dataset.gt_unexpected.find(stamp_ns);
  if (it == dataset.gt_unexpected.end()) return {};
  cv::Mat m = cv::imread(it->second.string(), cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw std::runtime_error(it->second.string() + ": cannot read image");
  return m;
}

std::optional<std::vector<double>> InterpolateJoints(const std::vector<JointSample>& samples,
                                                     int64_t stamp_ns, int64_t max_gap_ns) {
  if (samples.empty()) return std::nullopt;
  if (stamp_ns <= samples.front().stamp_ns) {
    if (samples.front().stamp_ns - stamp_ns > max_gap_ns) return std::nullopt;
    return samples.front().positions;
  }
  if (stamp_ns >= samples.back().stamp_ns) {
    if (stamp_ns - samples.back().stamp_ns > max_gap_ns) return std::nullopt;
    return samples.back().positions;
  }
  const auto hi = std::lower_bound(samples.begin(), samples.end(), stamp_ns,
                                   [](const JointSample& s, int64_t t) { return s.stamp_ns < t; });
  const auto lo = hi - 1;
  if (hi->stamp_ns == stamp_ns) return hi->positions;
  const double w = static_cast<double>(stamp_ns - lo->stamp_ns) /
                   static_cast<double>(hi->stamp_ns - lo->stamp_ns);
  std::vector<double> out(lo->positions.size());
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = (1.0 - w) * lo->positions[i] + w * hi->positions[i];
  }
  return out;
}

std::optional<Eigen::Isometry3d> PoseAt(const std::vector<PoseSample>& samples, int64_t stamp_ns) {
  const auto it =
      std::lower_bound(samples.begin(), samples.end(), stamp_ns,
                       [](const PoseSample& p, int64_t stamp) { return p.stamp_ns < stamp; });
  if (it == samples.end() || it->stamp_ns != stamp_ns) return std::nullopt;
  return it->pose;
}

std::optional<PlanarPose> InterpolatePlanar(const std::vector<PlanarPose>& samples,
                                            int64_t stamp_ns, int64_t max_gap_ns) {
  if (samples.empty()) return std::nullopt;
  if (stamp_ns <= samples.front().stamp_ns) {
    if (samples.front().stamp_ns - stamp_ns > max_gap_ns) return std::nullopt;
    PlanarPose p = samples.front();
    p.stamp_ns = stamp_ns;
    return p;
  }
  if (stamp_ns >= samples.back().stamp_ns) {
    if (stamp_ns - samples.back().stamp_ns > max_gap_ns) return std::nullopt;
    PlanarPose p = samples.back();
    p.stamp_ns = stamp_ns;
    return p;
  }
  const auto hi = std::lower_bound(samples.begin(), samples.end(), stamp_ns,
                                   [](const PlanarPose& s, int64_t t) { return s.stamp_ns < t; });
  const auto lo = hi - 1;
  const double w = static_cast<double>(stamp_ns - lo->stamp_ns) /
                   static_cast<double>(std::max<int64_t>(1, hi->stamp_ns - lo->stamp_ns));
  const double dtheta = std::remainder(hi->theta - lo->theta, 2.0 * std::numbers::pi);
  return PlanarPose{stamp_ns, (1 - w) * lo->x + w * hi->x, (1 - w) * lo->y + w * hi->y,
                    std::remainder(lo->theta + w * dtheta, 2.0 * std::numbers::pi)};
}

CameraSensor RectifiedPinholeSensor(int width, int height, double fx, double fy, double cx,
                                    double cy, const Eigen::Isometry3d& T_base_cam,
                                    double rate_hz) {
  CameraSensor s;
  s.width = width;
  s.height = height;
  s.fu = fx;
  s.fv = fy;
  s.cu = cx;
  s.cv = cy;
  s.distortion = {0, 0, 0, 0};
  s.T_BS = T_base_cam.matrix();
  s.rate_hz = rate_hz;
  return s;
}

}  // namespace epmap::dataset
