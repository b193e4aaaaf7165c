#include "perception/internal_model/learned_pose_model.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <stdexcept>

namespace epmap::internal_model {

namespace {

constexpr int kOutputs = 12;  // R row-major (9) then t (3): the paper's 12 output neurons

// The 12 outputs of a pose, in the network's order.
Eigen::Matrix<double, kOutputs, 1> PoseToOutputs(const Eigen::Isometry3d& T) {
  Eigen::Matrix<double, kOutputs, 1> y;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) y(3 * r + c) = T.linear()(r, c);
  }
  y.tail<3>() = T.translation();
  return y;
}

// Maps every row (one variable) to [-1, 1] by its range over the training set (MATLAB's
// mapminmax). A variable that never varies carries no information and maps to 0.
struct MinMaxScaling {
  Eigen::VectorXd lo, hi;

  static MinMaxScaling Fit(const Eigen::MatrixXd& data) {  // one sample per column
    return {data.rowwise().minCoeff(), data.rowwise().maxCoeff()};
  }
  Eigen::MatrixXd Forward(const Eigen::MatrixXd& data) const {
    Eigen::MatrixXd out(data.rows(), data.cols());
    for (Eigen::Index r = 0; r < data.rows(); ++r) {
      const double range = hi(r) - lo(r);
      if (range > 1e-12) {
        out.row(r) = ((data.row(r).array() - lo(r)) * (2.0 / range) - 1.0).matrix();
      } else {
        out.row(r).setZero();
      }
    }
    return out;
  }
  Eigen::VectorXd Inverse(const Eigen::VectorXd& s) const {
    Eigen::VectorXd out(s.size());
    for (Eigen::Index r = 0; r < s.size(); ++r) {
      const double range = hi(r) - lo(r);
      out(r) = range > 1e-12 ? lo(r) + (s(r) + 1.0) * 0.5 * range : lo(r);
    }
    return out;
  }
};

// One hidden layer of tanh units, linear outputs: y = W2 tanh(W1 x + b1) + b2.
struct Mlp {
  Eigen::MatrixXd w1;  // hidden x inputs
  Eigen::VectorXd b1;
  Eigen::MatrixXd w2;  // outputs x hidden
  Eigen::VectorXd b2;

  Eigen::Index Parameters() const { return w1.size() + b1.size() + w2.size() + b2.size(); }

  Eigen::MatrixXd Forward(const Eigen::MatrixXd& x) const {  // x: inputs x samples
    const Eigen::MatrixXd h = ((w1 * x).colwise() + b1).array().tanh().matrix();
    return (w2 * h).colwise() + b2;
  }

  Eigen::VectorXd Pack() const {
    Eigen::VectorXd p(Parameters());
    Eigen::Index k = 0;
    for (const Eigen::MatrixXd* m : {&w1, &w2}) {
      p.segment(k, m->size()) = m->reshaped();
      k += m->size();
      const Eigen::VectorXd& b = m == &w1 ? b1 : b2;
      p.segment(k, b.size()) = b;
      k += b.size();
    }
    return p;
  }
  void Unpack(const Eigen::VectorXd& p) {
    Eigen::Index k = 0;
    for (Eigen::MatrixXd* m : {&w1, &w2}) {
      m->reshaped() = p.segment(k, m->size());
      k += m->size();
      Eigen::VectorXd& b = m == &w1 ? b1 : b2;
      b = p.segment(k, b.size());
      k += b.size();
    }
  }

  // Residuals (outputs - targets, sample-major) and their Jacobian with respect to Pack()'s
  // parameters, by back-propagation through the two layers.
  using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  void Linearise(const Eigen::MatrixXd& x, const Eigen::MatrixXd& t, Eigen::VectorXd* r,
                 Jacobian* jac) const {
    const Eigen::Index n = x.cols(), hidden = w1.rows(), in = w1.cols(), out = w2.rows();
    const Eigen::MatrixXd h = ((w1 * x).colwise() + b1).array().tanh().matrix();
    const Eigen::MatrixXd y = (w2 * h).colwise() + b2;
    *r = (y - t).reshaped();
    jac->setZero(n * out, Parameters());
    const Eigen::Index off_b1 = w1.size(), off_w2 = off_b1 + hidden, off_b2 = off_w2 + w2.size();
    for (Eigen::Index s = 0; s < n; ++s) {
      const Eigen::ArrayXd dh = 1.0 - h.col(s).array().square();  // tanh'
      for (Eigen::Index k = 0; k < out; ++k) {
        auto row = jac->row(s * out + k);
        for (Eigen::Index j = 0; j < hidden; ++j) {
          const double g = w2(k, j) * dh(j);  // dy_k / d(pre-activation of hidden j)
          for (Eigen::Index i = 0; i < in; ++i) row(i * hidden + j) = g * x(i, s);  // col-major
          row(off_b1 + j) = g;
          row(off_w2 + j * out + k) = h(j, s);
        }
        row(off_b2 + k) = 1.0;
      }
    }
  }
};

// The error of the header (MSE per output on the scaled outputs), computed in the network's
// min-max space: output c's residual there times weight(c) is its residual on the scaled output.
double ScaledError(const Mlp& mlp, const Eigen::MatrixXd& x, const Eigen::MatrixXd& t,
                   const Eigen::VectorXd& weight) {
  if (x.cols() == 0) return 0.0;
  return (weight.asDiagonal() * (mlp.Forward(x) - t)).squaredNorm() / static_cast<double>(t.size());
}

void CheckFinite(const std::vector<double>& v, const char* what) {
  for (double x : v) {
    if (!std::isfinite(x)) throw std::invalid_argument(std::string(what) + " is not finite");
  }
}

// Samples (columns) of inputs and outputs, checked.
void ToMatrices(const std::vector<std::vector<double>>& inputs,
                const std::vector<Eigen::Isometry3d>& poses, size_t n_in, Eigen::MatrixXd* x,
                Eigen::MatrixXd* y) {
  if (inputs.size() != poses.size()) {
    throw std::invalid_argument("got " + std::to_string(inputs.size()) + " joint samples but " +
                                std::to_string(poses.size()) + " poses");
  }
  const auto n = static_cast<Eigen::Index>(inputs.size());
  x->resize(static_cast<Eigen::Index>(n_in), n);
  y->resize(kOutputs, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& in = inputs[static_cast<size_t>(i)];
    if (in.size() != n_in) {
      throw std::invalid_argument("sample " + std::to_string(i) + " has " +
                                  std::to_string(in.size()) + " joint values, expected " +
                                  std::to_string(n_in));
    }
    CheckFinite(in, "a joint value");
    x->col(i) = Eigen::Map<const Eigen::VectorXd>(in.data(), static_cast<Eigen::Index>(n_in));
    y->col(i) = PoseToOutputs(poses[static_cast<size_t>(i)]);
    if (!y->col(i).allFinite()) {
      throw std::invalid_argument("pose " + std::to_string(i) + " is not finite");
    }
  }
}

}  // namespace

void LearnedModelParams::Validate() const {
  if (hidden_units < 1) throw std::invalid_argument("hidden_units must be >= 1");
  if (!(target_validation_error > 0)) {
    throw std::invalid_argument("target_validation_error must be > 0");
  }
  if (!(train_share > 0) || !(validation_share > 0) || train_share + validation_share >= 1.0) {
    throw std::invalid_argument("train/validation shares must be > 0 and leave a test share");
  }
  if (max_epochs < 1) throw std::invalid_argument("max_epochs must be >= 1");
  if (!(learning_rate > 0) || momentum < 0 || momentum >= 1) {
    throw std::invalid_argument("learning_rate must be > 0 and momentum in [0, 1)");
  }
}

// Output c in the min-max space times weight(c) = the scaled output of the header.
Eigen::VectorXd OutputWeights(const MinMaxScaling& out_scale, double lever_arm) {
  Eigen::VectorXd w(kOutputs);
  for (int c = 0; c < kOutputs; ++c) {
    w(c) = 0.5 * (out_scale.hi(c) - out_scale.lo(c)) / (c < 9 ? 1.0 : lever_arm);
  }
  return w;
}

struct LearnedPoseModel::Impl {
  std::vector<std::string> joint_names;
  MinMaxScaling in_scale, out_scale;
  Eigen::VectorXd weight;  // OutputWeights()
  Mlp mlp;
  TrainingReport report;
};

LearnedPoseModel::LearnedPoseModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LearnedPoseModel::LearnedPoseModel(LearnedPoseModel&&) noexcept = default;
LearnedPoseModel& LearnedPoseModel::operator=(LearnedPoseModel&&) noexcept = default;
LearnedPoseModel::~LearnedPoseModel() = default;

const std::vector<std::string>& LearnedPoseModel::input_joint_names() const {
  return impl_->joint_names;
}
const TrainingReport& LearnedPoseModel::report() const {
  return impl_->report;
}

LearnedPoseModel LearnedPoseModel::Train(const std::vector<std::string>& joint_names,
                                         const std::vector<std::vector<double>>& inputs,
                                         const std::vector<Eigen::Isometry3d>& poses,
                                         const LearnedModelParams& params) {
  params.Validate();
  if (joint_names.empty()) throw std::invalid_argument("the learned model needs input joints");
  if (inputs.size() < 20) {
    throw std::invalid_argument("the learned model needs at least 20 samples, got " +
                                std::to_string(inputs.size()));
  }
  Eigen::MatrixXd x, y;
  ToMatrices(inputs, poses, joint_names.size(), &x, &y);
  const Eigen::Index n = x.cols(), n_in = x.rows();

  // Sec. III: shuffled, then 70% training, 15% validation, 15% test.
  std::vector<Eigen::Index> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 rng(params.seed);
  std::shuffle(order.begin(), order.end(), rng);
  const auto n_train = static_cast<Eigen::Index>(std::lround(params.train_share * n));
  const auto n_val = static_cast<Eigen::Index>(std::lround(params.validation_share * n));
  const auto take = [&](const Eigen::MatrixXd& m, Eigen::Index begin, Eigen::Index end) {
    Eigen::MatrixXd out(m.rows(), end - begin);
    for (Eigen::Index i = begin; i < end; ++i)
      out.col(i - begin) = m.col(order[static_cast<size_t>(i)]);
    return out;
  };
  auto impl = std::make_unique<Impl>();
  impl->joint_names = joint_names;
  impl->in_scale = MinMaxScaling::Fit(take(x, 0, n_train));
  impl->out_scale = MinMaxScaling::Fit(take(y, 0, n_train));
  double lever_arm = 0;
  for (Eigen::Index i = 0; i < n_train; ++i) {
    lever_arm = std::max(lever_arm, y.col(order[static_cast<size_t>(i)]).tail<3>().norm());
  }
  lever_arm = std::max(lever_arm, 1e-3);  // a camera at the base origin: millimetres
  impl->report.lever_arm_m = lever_arm;
  impl->weight = OutputWeights(impl->out_scale, lever_arm);
  const Eigen::VectorXd& weight = impl->weight;
  const auto& is = impl->in_scale;
  const auto& os = impl->out_scale;
  const Eigen::MatrixXd x_train = is.Forward(take(x, 0, n_train));
  const Eigen::MatrixXd y_train = os.Forward(take(y, 0, n_train));
  const Eigen::MatrixXd x_val = is.Forward(take(x, n_train, n_train + n_val));
  const Eigen::MatrixXd y_val = os.Forward(take(y, n_train, n_train + n_val));
  const Eigen::MatrixXd x_test = is.Forward(take(x, n_train + n_val, n));
  const Eigen::MatrixXd y_test = os.Forward(take(y, n_train + n_val, n));

  // Initial weights: small and random (hidden units start in tanh's linear range).
  Mlp& mlp = impl->mlp;
  const int hidden = params.hidden_units;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto random = [&](Eigen::Index rows, Eigen::Index cols, double scale) {
    Eigen::MatrixXd m(rows, cols);
    for (auto& v : m.reshaped()) v = scale * u(rng);
    return m;
  };
  mlp.w1 = random(hidden, n_in, 1.0 / std::sqrt(static_cast<double>(n_in)));
  mlp.b1 = random(hidden, 1, 0.5);
  mlp.w2 = random(kOutputs, hidden, 1.0 / std::sqrt(static_cast<double>(hidden)));
  mlp.b2 = Eigen::VectorXd::Zero(kOutputs);

  TrainingReport& report = impl->report;
  report.train_samples = static_cast<size_t>(x_train.cols());
  report.validation_samples = static_cast<size_t>(x_val.cols());
  report.test_samples = static_cast<size_t>(x_test.cols());
  // Early stopping (Sec. III): after every epoch the validation error decides; the weights kept
  // are those of the best validation error seen.
  Eigen::VectorXd w = mlp.Pack();
  Eigen::VectorXd best_w = w, velocity = Eigen::VectorXd::Zero(w.size());
  double best_val = ScaledError(mlp, x_val, y_val, weight);
  double mu = 1e-3;  // Levenberg-Marquardt damping
  Eigen::VectorXd r;
  Mlp::Jacobian jac;
  double train_err = ScaledError(mlp, x_train, y_train, weight);
  while (report.epochs < params.max_epochs && best_val >= params.target_validation_error) {
    mlp.Linearise(x_train, y_train, &r, &jac);
    // Residuals and Jacobian rows of the scaled outputs (sample-major: output = row % 12).
    for (Eigen::Index row = 0; row < r.size(); ++row) {
      r(row) *= weight(row % kOutputs);
      jac.row(row) *= weight(row % kOutputs);
    }
    if (params.method == LearnedModelParams::Method::kLevenbergMarquardt) {
      Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(jac.cols(), jac.cols());
      jtj.selfadjointView<Eigen::Lower>().rankUpdate(jac.transpose());
      jtj = jtj.selfadjointView<Eigen::Lower>();
      const Eigen::VectorXd jtr = jac.transpose() * r;
      bool improved = false;
      while (!improved && mu < 1e10) {
        Eigen::MatrixXd a = jtj;
        a.diagonal().array() += mu;
        const Eigen::VectorXd step = a.ldlt().solve(-jtr);
        mlp.Unpack(w + step);
        const double e = ScaledError(mlp, x_train, y_train, weight);
        if (std::isfinite(e) && e < train_err) {
          w += step;
          train_err = e;
          mu = std::max(mu * 0.1, 1e-12);
          improved = true;
        } else {
          mu *= 10.0;
        }
      }
      mlp.Unpack(w);
      if (!improved) break;  // a minimum of the training error: nothing more to learn
    } else {
      const Eigen::VectorXd grad = (2.0 / static_cast<double>(r.size())) * (jac.transpose() * r);
      velocity = params.momentum * velocity - params.learning_rate * grad;
      w += velocity;
      mlp.Unpack(w);
      train_err = ScaledError(mlp, x_train, y_train, weight);
      if (!std::isfinite(train_err)) {
        throw std::runtime_error("learned model training diverged; lower the learning rate");
      }
    }
    ++report.epochs;
    const double val = ScaledError(mlp, x_val, y_val, weight);
    report.validation_history.emplace_back(report.epochs, val);
    if (val < best_val) {
      best_val = val;
      best_w = w;
    }
  }
  mlp.Unpack(best_w);
  report.validation_error = best_val;
  report.reached_target = best_val < params.target_validation_error;
  report.train_error = ScaledError(mlp, x_train, y_train, weight);
  report.test_error = ScaledError(mlp, x_test, y_test, weight);

  LearnedPoseModel model(std::move(impl));
  // The same test set's errors in SI units.
  double rot2 = 0, trans2 = 0;
  for (Eigen::Index i = n_train + n_val; i < n; ++i) {
    const Eigen::Index src = order[static_cast<size_t>(i)];
    const Eigen::Isometry3d T = model.Predict(inputs[static_cast<size_t>(src)]);
    const Eigen::Isometry3d& truth = poses[static_cast<size_t>(src)];
    rot2 += std::pow(Eigen::AngleAxisd(truth.linear().transpose() * T.linear()).angle(), 2);
    trans2 += (truth.translation() - T.translation()).squaredNorm();
  }
  const auto n_test = static_cast<double>(n - n_train - n_val);
  model.impl_->report.test_rotation_rms_rad = std::sqrt(rot2 / n_test);
  model.impl_->report.test_translation_rms_m = std::sqrt(trans2 / n_test);
  return model;
}

Eigen::Isometry3d LearnedPoseModel::Predict(const std::vector<double>& joints) const {
  const auto n_in = static_cast<Eigen::Index>(impl_->joint_names.size());
  if (static_cast<Eigen::Index>(joints.size()) != n_in) {
    throw std::invalid_argument("the learned model expects " + std::to_string(n_in) +
                                " joint values, got " + std::to_string(joints.size()));
  }
  CheckFinite(joints, "a joint value");
  const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(joints.data(), n_in);
  const Eigen::VectorXd y =
      impl_->out_scale.Inverse(impl_->mlp.Forward(impl_->in_scale.Forward(q)));
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = y(3 * r + c);
  }
  // Nearest rotation (Frobenius norm): U V^T, with the sign fixed so that det = +1.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  T.translation() = y.tail<3>();
  if (!T.matrix().allFinite()) throw std::runtime_error("the learned model produced a NaN pose");
  return T;
}

double LearnedPoseModel::Error(const std::vector<std::vector<double>>& inputs,
                               const std::vector<Eigen::Isometry3d>& poses) const {
  Eigen::MatrixXd x, y;
  ToMatrices(inputs, poses, impl_->joint_names.size(), &x, &y);
  return ScaledError(impl_->mlp, impl_->in_scale.Forward(x), impl_->out_scale.Forward(y),
                     impl_->weight);
}

namespace {
cv::Mat ToCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}
Eigen::MatrixXd FromCv(const cv::FileNode& node) {
  cv::Mat m;
  node >> m;
  Eigen::MatrixXd out;
  if (!m.empty()) cv::cv2eigen(m, out);
  return out;
}
}  // namespace

void LearnedPoseModel::Save(const std::filesystem::path& path) const {
  cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error("cannot write learned model to " + path.string());
  const Impl& m = *impl_;
  fs << "format"
     << "epmap.learned_pose_model.v1";
  fs << "network"
     << "y = W2 tanh(W1 x + b1) + b2 on inputs/outputs scaled to [-1, 1]";
  fs << "outputs"
     << "R row-major (9), then t (3) of T_base_cam0";
  fs << "input_joints"
     << "[";
  for (const auto& n : m.joint_names) fs << n;
  fs << "]";
  fs << "input_min" << ToCv(m.in_scale.lo) << "input_max" << ToCv(m.in_scale.hi);
  fs << "output_min" << ToCv(m.out_scale.lo) << "output_max" << ToCv(m.out_scale.hi);
  fs << "W1" << ToCv(m.mlp.w1) << "b1" << ToCv(m.mlp.b1) << "W2" << ToCv(m.mlp.w2) << "b2"
     << ToCv(m.mlp.b2);
  const TrainingReport& r = m.report;
  fs << "report"
     << "{";
  fs << "train_samples" << static_cast<int>(r.train_samples) << "validation_samples"
     << static_cast<int>(r.validation_samples) << "test_samples" << static_cast<int>(r.test_samples)
     << "epochs" << r.epochs << "reached_target" << static_cast<int>(r.reached_target)
     << "train_error" << r.train_error << "validation_error" << r.validation_error << "test_error"
     << r.test_error << "test_rotation_rms_rad" << r.test_rotation_rms_rad
     << "test_translation_rms_m" << r.test_translation_rms_m;
  fs << "}";
  fs << "lever_arm_m" << r.lever_arm_m;
}

LearnedPoseModel LearnedPoseModel::Load(const std::filesystem::path& path) {
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error(path.string() + ": " + what);
  };
  if (!std::filesystem::exists(path)) fail("no such learned model file");
  cv::FileStorage fs;
  try {
    fs.open(path.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    fail(std::string("not a readable model file (") + e.what() + ")");
  }
  if (!fs.isOpened()) fail("cannot open");
  if (static_cast<std::string>(fs["format"]) != "epmap.learned_pose_model.v1") {
    fail("not an epmap learned pose model (format epmap.learned_pose_model.v1)");
  }
  auto impl = std::make_unique<Impl>();
  for (const auto& node : fs["input_joints"]) {
    impl->joint_names.push_back(static_cast<std::string>(node));
  }
  impl->in_scale = {FromCv(fs["input_min"]), FromCv(fs["input_max"])};
  impl->out_scale = {FromCv(fs["output_min"]), FromCv(fs["output_max"])};
  Mlp& mlp = impl->mlp;
  mlp.w1 = FromCv(fs["W1"]);
  mlp.b1 = FromCv(fs["b1"]);
  mlp.w2 = FromCv(fs["W2"]);
  mlp.b2 = FromCv(fs["b2"]);
  const auto n_in = static_cast<Eigen::Index>(impl->joint_names.size());
  const Eigen::Index hidden = mlp.w1.rows();
  const bool consistent =
      n_in > 0 && impl->in_scale.lo.size() == n_in && impl->in_scale.hi.size() == n_in &&
      impl->out_scale.lo.size() == kOutputs && impl->out_scale.hi.size() == kOutputs &&
      hidden > 0 && mlp.w1.cols() == n_in && mlp.b1.size() == hidden && mlp.w2.rows() == kOutputs &&
      mlp.w2.cols() == hidden && mlp.b2.size() == kOutputs;
  if (!consistent) fail("the network's sizes do not match its inputs and 12 outputs");
  const cv::FileNode rep = fs["report"];
  if (!rep.empty()) {
    TrainingReport& r = impl->report;
    r.train_samples = static_cast<size_t>(static_cast<int>(rep["train_samples"]));
    r.validation_samples = static_cast<size_t>(static_cast<int>(rep["validation_samples"]));
    r.test_samples = static_cast<size_t>(static_cast<int>(rep["test_samples"]));
    r.epochs = static_cast<int>(rep["epochs"]);
    r.reached_target = static_cast<int>(rep["reached_target"]) != 0;
    r.train_error = static_cast<double>(rep["train_error"]);
    r.validation_error = static_cast<double>(rep["validation_error"]);
    r.test_error = static_cast<double>(rep["test_error"]);
    r.test_rotation_rms_rad = static_cast<double>(rep["test_rotation_rms_rad"]);
    r.test_translation_rms_m = static_cast<double>(rep["test_translation_rms_m"]);
  }
  impl->report.lever_arm_m = static_cast<double>(fs["lever_arm_m"]);
  if (!(impl->report.lever_arm_m > 0)) fail("lever_arm_m is missing or not positive");
  impl->weight = OutputWeights(impl->out_scale, impl->report.lever_arm_m);
  return LearnedPoseModel(std::move(impl));
}

}  // namespace epmap::internal_model
