#include "perception/calibration/eye_hand_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "perception/calibration/calibration_error.h"
#include "perception/calibration/json_lite.h"

namespace epmap::calibration {

const char* ToString(EyeHandMethod method) {
  switch (method) {
    case EyeHandMethod::kSe3:
      return "se3";
    case EyeHandMethod::kSe3Scale:
      return "se3-scale";
    case EyeHandMethod::kMixture:
      return "mixture";
  }
  return "unknown";
}

EyeHandMethod ParseEyeHandMethod(std::string_view name) {
  if (name == "se3") return EyeHandMethod::kSe3;
  if (name == "se3-scale") return EyeHandMethod::kSe3Scale;
  if (name == "mixture") return EyeHandMethod::kMixture;
  throw CalibrationError(ErrorCode::kInvalidInput, "unknown eye-hand method '" + std::string(name) +
                                                       "' (use se3, se3-scale or mixture)");
}

Eigen::Matrix4d LinearExpert::Matrix() const {
  Eigen::Matrix4d h = Eigen::Matrix4d::Identity();
  h.topLeftCorner<3, 3>() = Linear();
  h.topRightCorner<3, 1>() = translation;
  return h;
}

EyeHandModel::EyeHandModel() : experts_(1), covariance_inverse_(1, Eigen::Matrix3d::Identity()) {}

EyeHandModel::EyeHandModel(EyeHandMethod method, std::vector<LinearExpert> experts)
    : method_(method), experts_(std::move(experts)) {
  const auto fail = [](size_t i, const std::string& what) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "eye-hand model expert " + std::to_string(i) + ": " + what);
  };
  if (experts_.empty()) {
    throw CalibrationError(ErrorCode::kInvalidInput, "eye-hand model has no expert");
  }
  if (method_ != EyeHandMethod::kMixture && experts_.size() != 1) {
    throw CalibrationError(ErrorCode::kInvalidInput, std::string("a '") + ToString(method_) +
                                                         "' model has exactly one transform, got " +
                                                         std::to_string(experts_.size()));
  }
  for (size_t i = 0; i < experts_.size(); ++i) {
    const auto& e = experts_[i];
    if (!e.rotation.allFinite() || !e.translation.allFinite() || !e.scale.allFinite() ||
        !e.centroid.allFinite() || !e.covariance.allFinite()) {
      fail(i, "non-finite parameter");
    }
    if ((e.rotation.transpose() * e.rotation - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
        e.rotation.determinant() < 0) {
      fail(i, "'rotation' is not a rotation matrix");
    }
    if (e.scale.minCoeff() <= 0) fail(i, "scales must be positive");
    if (method_ == EyeHandMethod::kSe3 && (e.scale - Eigen::Vector3d::Ones()).norm() > 1e-12) {
      fail(i, "an se3 model has unit scale");
    }
    const Eigen::LLT<Eigen::Matrix3d> llt(e.covariance);
    if (method_ == EyeHandMethod::kMixture &&
        (llt.info() != Eigen::Success ||
         (e.covariance - e.covariance.transpose()).norm() > 1e-9 * e.covariance.norm())) {
      fail(i, "'covariance' must be symmetric positive definite");
    }
    covariance_inverse_.push_back(method_ == EyeHandMethod::kMixture
                                      ? Eigen::Matrix3d(llt.solve(Eigen::Matrix3d::Identity()))
                                      : Eigen::Matrix3d::Identity());
  }
}

Eigen::VectorXd EyeHandModel::Weights(const Eigen::Vector3d& x_a) const {
  const auto k = static_cast<Eigen::Index>(experts_.size());
  Eigen::VectorXd w(k);
  if (k == 1) {
    w(0) = 1.0;
    return w;
  }
  // Eq. 10: w_i = exp(-d_i^2) / sum_j exp(-d_j^2), d_i^2 = (c_i - x)^T S_i^-1 (c_i - x).
  // Exponents are shifted by the largest one so that far points do not underflow to 0/0.
  Eigen::VectorXd exponent(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const Eigen::Vector3d d = experts_[static_cast<size_t>(i)].centroid - x_a;
    exponent(i) = -d.dot(covariance_inverse_[static_cast<size_t>(i)] * d);
  }
  const double top = exponent.maxCoeff();
  w = (exponent.array() - top).exp();
  return w / w.sum();
}

Eigen::Vector3d EyeHandModel::Apply(const Eigen::Vector3d& x_a) const {
  if (experts_.size() == 1) return experts_[0].Apply(x_a);
  const Eigen::VectorXd w = Weights(x_a);
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < experts_.size(); ++i) {
    out += w(static_cast<Eigen::Index>(i)) * experts_[i].Apply(x_a);
  }
  return out;
}

Eigen::Matrix3Xd EyeHandModel::Apply(const Eigen::Matrix3Xd& x_a) const {
  Eigen::Matrix3Xd out(3, x_a.cols());
  for (Eigen::Index i = 0; i < x_a.cols(); ++i) out.col(i) = Apply(Eigen::Vector3d(x_a.col(i)));
  return out;
}

namespace {

json::Value MatrixJson(const Eigen::Matrix3d& m) {
  double v[9];
  for (int i = 0; i < 9; ++i) v[i] = m(i / 3, i % 3);  // row-major
  return json::Value::Numbers(v, 9);
}

Eigen::Matrix3d MatrixFrom(const json::Value& v, const std::string& what) {
  const auto n = v.AsNumbers(9, what);
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = n[static_cast<size_t>(i)];
  return m;
}

Eigen::Vector3d VectorFrom(const json::Value& v, const std::string& what) {
  const auto n = v.AsNumbers(3, what);
  return {n[0], n[1], n[2]};
}

}  // namespace

std::string EyeHandModel::ToJson() const {
  json::Value root = json::Value::Object();
  root.Set("type", json::Value::String("eye-hand"));
  root.Set("format_version", json::Value::Number(1));
  root.Set("method", json::Value::String(ToString(method_)));
  json::Value experts = json::Value::Array();
  for (const auto& e : experts_) {
    json::Value x = json::Value::Object();
    x.Set("rotation", MatrixJson(e.rotation));
    x.Set("scale", json::Value::Numbers(e.scale.data(), 3));
    x.Set("translation", json::Value::Numbers(e.translation.data(), 3));
    if (method_ == EyeHandMethod::kMixture) {
      x.Set("centroid", json::Value::Numbers(e.centroid.data(), 3));
      x.Set("covariance", MatrixJson(e.covariance));
    }
    experts.array.push_back(std::move(x));
  }
  root.Set("experts", std::move(experts));
  return json::Write(root);
}

EyeHandModel EyeHandModel::FromJson(std::string_view text) {
  try {
    const json::Value root = json::Parse(text);
    if (root.Get("type").AsString("type") != "eye-hand") {
      throw std::runtime_error("not an eye-hand model (type is '" + root.Get("type").string + "')");
    }
    if (root.Get("format_version").AsNumber("format_version") != 1) {
      throw std::runtime_error("unsupported format_version");
    }
    const EyeHandMethod method = ParseEyeHandMethod(root.Get("method").AsString("method"));
    const json::Value& list = root.Get("experts");
    if (list.type != json::Value::Type::kArray) throw std::runtime_error("'experts' not an array");
    std::vector<LinearExpert> experts;
    for (const auto& x : list.array) {
      LinearExpert e;
      e.rotation = MatrixFrom(x.Get("rotation"), "rotation");
      e.scale = VectorFrom(x.Get("scale"), "scale");
      e.translation = VectorFrom(x.Get("translation"), "translation");
      if (method == EyeHandMethod::kMixture) {
        e.centroid = VectorFrom(x.Get("centroid"), "centroid");
        e.covariance = MatrixFrom(x.Get("covariance"), "covariance");
      }
      experts.push_back(e);
    }
    return EyeHandModel(method, std::move(experts));
  } catch (const CalibrationError&) {
    throw;
  } catch (const std::exception& e) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           std::string("cannot read eye-hand model: ") + e.what());
  }
}

ErrorSummary Summarise(std::vector<double> d) {
  ErrorSummary s;
  s.count = d.size();
  if (d.empty()) return s;
  double sum = 0, sum2 = 0;
  for (double v : d) {
    sum += v;
    sum2 += v * v;
    s.max_m = std::max(s.max_m, v);
  }
  s.mean_m = sum / static_cast<double>(d.size());
  s.rmse_m = std::sqrt(sum2 / static_cast<double>(d.size()));
  const auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  s.median_m = *mid;
  return s;
}

ErrorSummary EvaluateModel(const EyeHandModel& model, const std::vector<EyeHandSample>& samples) {
  std::vector<double> d;
  d.reserve(samples.size());
  for (const auto& s : samples) d.push_back((s.xb - model.Apply(s.xa)).norm());
  return Summarise(std::move(d));
}

ErrorSummary EvaluateUncalibrated(const std::vector<EyeHandSample>& samples) {
  std::vector<double> d;
  d.reserve(samples.size());
  for (const auto& s : samples) d.push_back((s.xb - s.xa).norm());
  return Summarise(std::move(d));
}

}  // namespace epmap::calibration
