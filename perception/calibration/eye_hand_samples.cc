#include "perception/calibration/eye_hand_samples.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "perception/calibration/calibration_error.h"

namespace epmap::calibration {

namespace {

[[noreturn]] void Fail(const std::filesystem::path& csv, size_t line, const std::string& what) {
  throw CalibrationError(ErrorCode::kInvalidInput,
                         csv.string() + ":" + std::to_string(line) + ": " + what);
}

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  const auto e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

}  // namespace

std::vector<EyeHandSample> ReadEyeHandCsv(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "cannot open eye-hand samples file " + csv.string());
  }
  std::vector<EyeHandSample> samples;
  std::string line;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    line = Trim(line);
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) fields.push_back(Trim(field));
    if (fields.size() != 7 && fields.size() != 8) {
      Fail(csv, line_no,
           "expected 8 fields (timestamp, xa, ya, za, xb, yb, zb, path), got " +
               std::to_string(fields.size()));
    }
    EyeHandSample s;
    try {
      size_t used = 0;
      s.stamp_ns = std::stoll(fields[0], &used);
      if (used != fields[0].size()) throw std::invalid_argument(fields[0]);
      for (int i = 0; i < 6; ++i) {
        const double v = std::stod(fields[static_cast<size_t>(i + 1)], &used);
        if (used != fields[static_cast<size_t>(i + 1)].size()) throw std::invalid_argument("");
        (i < 3 ? s.xa : s.xb)(i % 3) = v;
      }
    } catch (const std::exception&) {
      Fail(csv, line_no, "not a number in '" + line + "'");
    }
    if (!s.xa.allFinite() || !s.xb.allFinite()) Fail(csv, line_no, "non-finite coordinate");
    s.path = fields.size() == 8 ? fields[7] : std::string();
    samples.push_back(std::move(s));
  }
  if (samples.empty()) Fail(csv, line_no, "no samples in the file");
  return samples;
}

void WriteEyeHandCsv(const std::filesystem::path& csv, const std::vector<EyeHandSample>& samples) {
  std::ofstream out(csv);
  if (!out) {
    throw CalibrationError(ErrorCode::kInvalidInput, "cannot write " + csv.string());
  }
  out << "#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path\n";
  char buf[256];
  for (const auto& s : samples) {
    std::snprintf(buf, sizeof buf, "%lld,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,",
                  static_cast<long long>(s.stamp_ns), s.xa.x(), s.xa.y(), s.xa.z(), s.xb.x(),
                  s.xb.y(), s.xb.z());
    out << buf << s.path << "\n";
  }
}

void ValidateSamples(const std::vector<EyeHandSample>& samples) {
  for (size_t i = 0; i < samples.size(); ++i) {
    if (!samples[i].xa.allFinite() || !samples[i].xb.allFinite()) {
      throw CalibrationError(ErrorCode::kInvalidInput,
                             "sample " + std::to_string(i) + " (stamp " +
                                 std::to_string(samples[i].stamp_ns) + ", path '" +
                                 samples[i].path +
                                 "') has a non-finite coordinate: drop it before fitting");
    }
  }
}

std::vector<std::string> PathNames(const std::vector<EyeHandSample>& samples) {
  std::vector<std::string> names;
  for (const auto& s : samples) {
    if (std::find(names.begin(), names.end(), s.path) == names.end()) names.push_back(s.path);
  }
  return names;
}

std::vector<EyeHandSample> SelectPaths(const std::vector<EyeHandSample>& samples,
                                       const std::vector<std::string>& paths, bool keep) {
  std::vector<EyeHandSample> out;
  for (const auto& s : samples) {
    const bool listed = std::find(paths.begin(), paths.end(), s.path) != paths.end();
    if (listed == keep) out.push_back(s);
  }
  return out;
}

PathSplit SplitByPaths(const std::vector<EyeHandSample>& samples, double test_share,
                       uint64_t seed) {
  std::vector<std::string> paths = PathNames(samples);
  if (paths.size() < 2) {
    throw CalibrationError(
        ErrorCode::kInvalidInput,
        "a split by paths needs at least 2 paths, got " + std::to_string(paths.size()));
  }
  if (!(test_share > 0.0 && test_share < 1.0)) {
    throw CalibrationError(ErrorCode::kInvalidInput, "the test share must be in (0, 1)");
  }
  std::sort(paths.begin(), paths.end());
  std::mt19937_64 rng(seed);
  for (size_t i = paths.size() - 1; i > 0; --i) {  // Fisher-Yates, library-independent draws
    const auto j = static_cast<size_t>(static_cast<double>(rng() >> 11) * 0x1.0p-53 *
                                       static_cast<double>(i + 1));
    std::swap(paths[i], paths[j]);
  }
  const auto p = static_cast<long>(paths.size());
  const long n_test = std::clamp(std::lround(test_share * static_cast<double>(p)), 1L, p - 1);
  PathSplit split;
  split.test_paths.assign(paths.begin(), paths.begin() + n_test);
  std::sort(split.test_paths.begin(), split.test_paths.end());
  split.train = SelectPaths(samples, split.test_paths, false);
  split.test = SelectPaths(samples, split.test_paths, true);
  return split;
}

Eigen::Matrix3Xd PointsA(const std::vector<EyeHandSample>& samples) {
  Eigen::Matrix3Xd m(3, static_cast<Eigen::Index>(samples.size()));
  for (size_t i = 0; i < samples.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = samples[i].xa;
  return m;
}

Eigen::Matrix3Xd PointsB(const std::vector<EyeHandSample>& samples) {
  Eigen::Matrix3Xd m(3, static_cast<Eigen::Index>(samples.size()));
  for (size_t i = 0; i < samples.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = samples[i].xb;
  return m;
}

PointSpread MeasureSpread(const Eigen::Matrix3Xd& points) {
  PointSpread s;
  if (points.cols() == 0) return s;
  s.mean = points.rowwise().mean();
  const Eigen::Matrix3Xd centred = points.colwise() - s.mean;
  const Eigen::Matrix3d cov = centred * centred.transpose() / static_cast<double>(points.cols());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // Eigen sorts ascending; we report descending.
  for (int i = 0; i < 3; ++i) {
    s.sigma(i) = std::sqrt(std::max(0.0, eig.eigenvalues()(2 - i)));
    s.axes.col(i) = eig.eigenvectors().col(2 - i);
  }
  return s;
}

}  // namespace epmap::calibration
