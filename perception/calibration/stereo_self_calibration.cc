#include "perception/calibration/stereo_self_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlopt.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "perception/calibration/json_lite.h"
#include "perception/calibration/mixture.h"
#include "perception/calibration/se3_fit.h"

namespace epmap::calibration {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

cv::Matx33d ToCv(const Eigen::Matrix3d& m) {
  cv::Matx33d out;
  for (int i = 0; i < 9; ++i) out.val[i] = m(i / 3, i % 3);
  return out;
}

bool AllZero(const std::vector<double>& d) {
  return std::all_of(d.begin(), d.end(), [](double v) { return v == 0.0; });
}

void CheckCamera(const CameraIntrinsics& c, const char* name) {
  if (c.width <= 0 || c.height <= 0 || !c.k.allFinite() || c.k(0, 0) <= 0 || c.k(1, 1) <= 0) {
    throw CalibrationError(
        ErrorCode::kInvalidInput,
        std::string(name) + ": intrinsics need a positive size and focal length");
  }
}

cv::Mat Gray(const cv::Mat& img) {
  if (img.channels() == 1) return img;
  cv::Mat g;
  cv::cvtColor(img, g, img.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return g;
}

// Paper 001, Sec. III-A.1: features are taken on undistorted images (same K kept).
cv::Mat Undistort(const cv::Mat& raw, const CameraIntrinsics& cam) {
  const cv::Mat gray = Gray(raw);
  if (AllZero(cam.distortion)) return gray;
  cv::Mat out;
  const cv::Matx33d k = ToCv(cam.k);
  const cv::Mat d(cam.distortion, true);
  if (cam.distortion_model == "equidistant") {
    cv::fisheye::undistortImage(gray, out, k, d, k);
  } else {
    cv::undistort(gray, out, k, d, k);
  }
  return out;
}

void CheckImage(const cv::Mat& img, const CameraIntrinsics& cam, const std::string& what) {
  if (img.empty()) throw CalibrationError(ErrorCode::kInvalidInput, what + " is empty");
  if (img.cols != cam.width || img.rows != cam.height) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           what + " is " + std::to_string(img.cols) + "x" +
                               std::to_string(img.rows) + " but its camera is " +
                               std::to_string(cam.width) + "x" + std::to_string(cam.height));
  }
}

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Refinement of (R, t) of x_right = R x_left + t, |t| = 1, by minimising a Cauchy-robustified
// Sampson error in pixels over the RANSAC inliers (NLopt BOBYQA, 5 parameters: a rotation
// vector perturbing R0 and two tangent coordinates of t around t0). With a baseline-direction
// prior, the MAP cost adds noise^2 * (angle(t_01, t_01 prior) / sigma)^2 to the sum.
struct RefineContext {
  const std::vector<Eigen::Vector2d>* left;
  const std::vector<Eigen::Vector2d>* right;
  Eigen::Matrix3d kl_inv, kr_inv_t, r0;
  Eigen::Vector3d t0, u1, u2;
  double scale2;
  Eigen::Vector3d prior_t01 = Eigen::Vector3d::UnitX();  // unit, cam0 frame
  double prior_weight = 0.0;                             // noise_px^2 / sigma_rad^2

  void Decode(const double* x, Eigen::Matrix3d* r, Eigen::Vector3d* t) const {
    *r = r0 * ExpSo3(Eigen::Vector3d(x[0], x[1], x[2]));
    *t = (t0 + x[3] * u1 + x[4] * u2).normalized();
  }
};

double RefineObjective(unsigned, const double* x, double*, void* data) {
  const auto* c = static_cast<const RefineContext*>(data);
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  c->Decode(x, &r, &t);
  const Eigen::Matrix3d f = c->kr_inv_t * Hat(t) * r * c->kl_inv;
  double cost = 0;
  for (size_t i = 0; i < c->left->size(); ++i) {
    const double d = SampsonDistance(f, (*c->left)[i], (*c->right)[i]);
    cost += c->scale2 * std::log1p(d * d / c->scale2);
  }
  if (c->prior_weight > 0) {
    const Eigen::Vector3d t01 = -(r.transpose() * t);  // cam1's centre in cam0
    const double angle = std::atan2(t01.cross(c->prior_t01).norm(), t01.dot(c->prior_t01));
    cost += c->prior_weight * angle * angle;
  }
  return cost / static_cast<double>(c->left->size());
}

}  // namespace

double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * kRadToDeg;
}

double DirectionAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  const double s = a.normalized().cross(b.normalized()).norm();
  return std::atan2(s, c) * kRadToDeg;
}

Eigen::Isometry3d KinematicPrior(const kinematics::UrdfChain& chain,
                                 const std::vector<double>& joints) {
  if (!chain.has_cam1()) {
    throw CalibrationError(ErrorCode::kInvalidInput, "the URDF has no right camera link '" +
                                                         chain.camera_links().right +
                                                         "': no kinematic stereo prior");
  }
  try {
    return chain.Cam0Pose(joints).inverse() * chain.Cam1Pose(joints);
  } catch (const std::exception& e) {
    throw CalibrationError(ErrorCode::kInvalidInput, std::string("kinematic prior: ") + e.what());
  }
}

Matrix34d LeftCameraMatrix(const CameraIntrinsics& cam0) {
  Matrix34d p = Matrix34d::Zero();
  p.leftCols<3>() = cam0.k;
  return p;
}

Matrix34d RightCameraMatrix(const CameraIntrinsics& cam1, const Eigen::Isometry3d& T_cam0_cam1) {
  const Eigen::Isometry3d T_cam1_cam0 = T_cam0_cam1.inverse();
  Matrix34d rt;
  rt.leftCols<3>() = T_cam1_cam0.linear();
  rt.col(3) = T_cam1_cam0.translation();
  return cam1.k * rt;
}

void MatchSift(const cv::Mat& left, const cv::Mat& right, int max_features, double ratio_test,
               bool mutual_best, std::vector<Eigen::Vector2d>* left_points,
               std::vector<Eigen::Vector2d>* right_points, int* keypoints_left,
               int* keypoints_right) {
  const cv::Ptr<cv::SIFT> sift = cv::SIFT::create(std::max(0, max_features));
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  sift->detectAndCompute(Gray(left), cv::noArray(), kl, dl);
  sift->detectAndCompute(Gray(right), cv::noArray(), kr, dr);
  if (keypoints_left) *keypoints_left = static_cast<int>(kl.size());
  if (keypoints_right) *keypoints_right = static_cast<int>(kr.size());
  left_points->clear();
  right_points->clear();
  if (kl.size() < 2 || kr.size() < 2) return;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> forward;
  matcher.knnMatch(dl, dr, forward, 2);
  std::vector<int> backward_best;
  if (mutual_best) {
    std::vector<cv::DMatch> backward;
    matcher.match(dr, dl, backward);
    backward_best.assign(kr.size(), -1);
    for (const auto& m : backward) backward_best[static_cast<size_t>(m.queryIdx)] = m.trainIdx;
  }
  for (const auto& m : forward) {
    if (m.size() < 2 || !(m[0].distance < ratio_test * m[1].distance)) continue;
    if (mutual_best && backward_best[static_cast<size_t>(m[0].trainIdx)] != m[0].queryIdx) {
      continue;
    }
    const cv::Point2f& a = kl[static_cast<size_t>(m[0].queryIdx)].pt;
    const cv::Point2f& b = kr[static_cast<size_t>(m[0].trainIdx)].pt;
    left_points->emplace_back(a.x, a.y);
    right_points->emplace_back(b.x, b.y);
  }
}

StereoSelfCalibrationResult SelfCalibrateStereo(const CameraIntrinsics& cam0,
                                                const CameraIntrinsics& cam1,
                                                const std::vector<StereoView>& views,
                                                const StereoSelfCalibrationParams& params,
                                                const ProgressCallback& progress) {
  CheckCamera(cam0, "cam0");
  CheckCamera(cam1, "cam1");
  if (views.empty()) {
    throw CalibrationError(ErrorCode::kInvalidInput, "stereo self-calibration needs a frame");
  }
  const Eigen::Isometry3d prior = views.front().T_cam0_cam1_prior;
  const double prior_baseline = prior.translation().norm();
  if (!prior.matrix().allFinite() || prior_baseline < 1e-6) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           "the kinematic prior T_cam0_cam1 must be finite with a non-zero "
                           "baseline");
  }
  for (size_t v = 0; v < views.size(); ++v) {
    const std::string tag = "frame " + std::to_string(v);
    CheckImage(views[v].left, cam0, tag + " left image");
    CheckImage(views[v].right, cam1, tag + " right image");
    const auto& p = views[v].T_cam0_cam1_prior;
    const double spread = std::max(RotationAngleDeg(prior.linear(), p.linear()),
                                   DirectionAngleDeg(prior.translation(), p.translation()));
    if (!(spread <= params.max_view_prior_spread_deg)) {
      throw CalibrationError(ErrorCode::kInvalidInput,
                             tag + "'s eye configuration differs from frame 0's by " +
                                 Fmt("%.3f", spread) +
                                 " deg: accumulate matches only over frames with the same "
                                 "vergence (tolerance " +
                                 Fmt("%.3f", params.max_view_prior_spread_deg) + " deg)");
    }
  }

  StereoSelfCalibrationResult result;
  const double focal = 0.25 * (cam0.k(0, 0) + cam0.k(1, 1) + cam1.k(0, 0) + cam1.k(1, 1));
  result.prior_gate_px = params.prior_gate_px > 0
                             ? params.prior_gate_px
                             : focal * std::tan(params.max_rotation_deviation_deg / kRadToDeg) +
                                   2.0 * params.ransac.threshold_px;
  result.f_prior = FundamentalFromProjections(LeftCameraMatrix(cam0),
                                              RightCameraMatrix(cam1, prior));  // Eq. 4-6

  // Features, matches and the kinematic gate, frame by frame.
  std::vector<Eigen::Vector2d> gl, gr;
  for (size_t v = 0; v < views.size(); ++v) {
    const cv::Mat ul = Undistort(views[v].left, cam0);
    const cv::Mat ur = Undistort(views[v].right, cam1);
    std::vector<Eigen::Vector2d> ml, mr;
    int kl = 0, kr = 0;
    MatchSift(ul, ur, params.max_features, params.ratio_test, params.mutual_best, &ml, &mr, &kl,
              &kr);
    result.keypoints_left += kl;
    result.keypoints_right += kr;
    result.putative_matches += static_cast<int>(ml.size());
    const Eigen::Matrix3d fk = FundamentalFromProjections(
        LeftCameraMatrix(cam0), RightCameraMatrix(cam1, views[v].T_cam0_cam1_prior));
    for (size_t i = 0; i < ml.size(); ++i) {
      if (SampsonDistance(fk, ml[i], mr[i]) < result.prior_gate_px) {
        gl.push_back(ml[i]);
        gr.push_back(mr[i]);
      }
    }
    ReportProgress(progress,
                   {"features", v + 1, 0.0,
                    0.5 * static_cast<double>(v + 1) / static_cast<double>(views.size())});
  }
  result.prior_consistent_matches = static_cast<int>(gl.size());
  const int min_kp = std::min(result.keypoints_left, result.keypoints_right);
  if (min_kp < params.min_keypoints) {
    throw CalibrationError(ErrorCode::kInsufficientFeatures,
                           "not enough textured features: " + std::to_string(min_kp) +
                               " SIFT keypoints in the poorer image (need " +
                               std::to_string(params.min_keypoints) +
                               "); point the eyes at a textured scene or use more frames");
  }
  if (result.prior_consistent_matches < params.min_matches) {
    throw CalibrationError(
        ErrorCode::kInsufficientFeatures,
        "not enough matches: " + std::to_string(result.prior_consistent_matches) + " of " +
            std::to_string(result.putative_matches) +
            " putative matches agree with the kinematic prior within " +
            Fmt("%.1f", result.prior_gate_px) + " px (need " + std::to_string(params.min_matches) +
            "); the scene lacks distinctive texture, or the eyes are far from their encoders");
  }

  // F by RANSAC over the normalised 8-point algorithm.
  const RansacResult ransac =
      RansacFundamental(gl, gr, params.ransac, ProgressSubrange(progress, 0.5, 0.8));
  result.ransac_iterations = ransac.iterations;
  if (ransac.inliers < params.min_inliers) {
    throw CalibrationError(ErrorCode::kInsufficientFeatures,
                           "only " + std::to_string(ransac.inliers) +
                               " matches agree with one fundamental matrix (need " +
                               std::to_string(params.min_inliers) + ")");
  }
  // A homography explaining (almost) every F inlier leaves F undetermined (plane, or points
  // so far away that there is no parallax).
  const RansacResult h =
      RansacHomography(gl, gr, params.homography_threshold_px, 500, params.ransac.seed + 1);
  result.homography_inliers = h.inliers;
  const double h_share = static_cast<double>(h.inliers) / static_cast<double>(ransac.inliers);
  if (h_share >= params.planar_inlier_ratio) {
    throw CalibrationError(ErrorCode::kPlanarScene,
                           "scene is planar (or has no parallax): a homography explains " +
                               std::to_string(h.inliers) + " of the " +
                               std::to_string(ransac.inliers) +
                               " matches, so F is not determined; look at a scene with depth");
  }

  for (size_t i = 0; i < gl.size(); ++i) {
    if (ransac.inlier[i]) {
      result.inlier_left.push_back(gl[i]);
      result.inlier_right.push_back(gr[i]);
    }
  }
  // Eq. 7 and the decomposition in front of both cameras.
  Eigen::Matrix3d e = EssentialFromFundamental(ransac.f, cam0.k, cam1.k);
  const Eigen::Matrix3d kl_inv = cam0.k.inverse();
  const Eigen::Matrix3d kr_inv = cam1.k.inverse();
  std::vector<Eigen::Vector2d> nl, nr;
  for (size_t i = 0; i < result.inlier_left.size(); ++i) {
    nl.push_back((kl_inv * result.inlier_left[i].homogeneous()).hnormalized());
    nr.push_back((kr_inv * result.inlier_right[i].homogeneous()).hnormalized());
  }
  const RelativePose pose = ChooseByChirality(DecomposeEssential(e, nl, nr));
  if (pose.in_front * 2 < static_cast<int>(nl.size())) {
    throw CalibrationError(ErrorCode::kNotConverged,
                           "no decomposition of E puts most matches in front of both cameras (" +
                               std::to_string(pose.in_front) + " of " + std::to_string(nl.size()) +
                               "): F is unreliable");
  }
  Eigen::Matrix3d r = pose.r;
  Eigen::Vector3d t = pose.t;

  if (params.refine) {
    RefineContext ctx;
    ctx.left = &result.inlier_left;
    ctx.right = &result.inlier_right;
    ctx.kl_inv = kl_inv;
    ctx.kr_inv_t = kr_inv.transpose();
    ctx.r0 = r;
    ctx.t0 = t;
    ctx.u1 = t.unitOrthogonal();
    ctx.u2 = t.cross(ctx.u1);
    ctx.scale2 = params.ransac.threshold_px * params.ransac.threshold_px;
    if (params.baseline_direction_prior_sigma_deg > 0) {
      const double sigma = params.baseline_direction_prior_sigma_deg / kRadToDeg;
      ctx.prior_t01 = prior.translation().normalized();
      ctx.prior_weight = params.feature_noise_px * params.feature_noise_px / (sigma * sigma);
    }
    nlopt::opt opt(nlopt::LN_BOBYQA, 5);
    opt.set_min_objective(RefineObjective, &ctx);
    opt.set_xtol_abs(1e-10);
    opt.set_maxeval(3000);
    opt.set_initial_step(1e-3);
    std::vector<double> x(5, 0.0);
    double cost = 0;
    try {
      opt.optimize(x, cost);
    } catch (const nlopt::roundoff_limited&) {
      // best point is in x
    } catch (const std::exception& ex) {
      throw CalibrationError(ErrorCode::kNotConverged,
                             std::string("refinement of R, t failed: ") + ex.what());
    }
    ctx.Decode(x.data(), &r, &t);
    ReportProgress(progress, {"refine", static_cast<uint64_t>(opt.get_numevals()), cost, 0.95});
  }
  const Eigen::Matrix3d hat_t = Hat(t);
  result.e = hat_t * r;
  result.f = kr_inv.transpose() * result.e * kl_inv;
  result.f /= result.f.norm();
  double sum2 = 0;
  for (size_t i = 0; i < result.inlier_left.size(); ++i) {
    const double d = SampsonDistance(result.f, result.inlier_left[i], result.inlier_right[i]);
    sum2 += d * d;
  }

  // x_right = R x_left + t is T_cam1_cam0; the model stores T_cam0_cam1, scaled to the baseline.
  const double baseline = params.baseline_m > 0 ? params.baseline_m : prior_baseline;
  Eigen::Isometry3d T_cam1_cam0 = Eigen::Isometry3d::Identity();
  T_cam1_cam0.linear() = r;
  T_cam1_cam0.translation() = t * baseline;
  StereoExtrinsicsModel& m = result.model;
  m.T_cam0_cam1 = T_cam1_cam0.inverse();
  m.inliers = static_cast<int>(result.inlier_left.size());
  m.rms_sampson_px = std::sqrt(sum2 / std::max<size_t>(1, result.inlier_left.size()));
  m.rotation_deviation_deg = RotationAngleDeg(prior.linear(), m.T_cam0_cam1.linear());
  m.baseline_direction_deviation_deg =
      DirectionAngleDeg(prior.translation(), m.T_cam0_cam1.translation());
  if (m.rotation_deviation_deg > params.max_rotation_deviation_deg ||
      m.baseline_direction_deviation_deg > params.max_baseline_direction_deviation_deg) {
    throw CalibrationError(
        ErrorCode::kRejectedByPrior,
        "the recovered extrinsics are too far from the kinematic prior (rotation " +
            Fmt("%.2f", m.rotation_deviation_deg) + " deg, baseline direction " +
            Fmt("%.2f", m.baseline_direction_deviation_deg) + " deg; tolerance " +
            Fmt("%.2f", params.max_rotation_deviation_deg) + " / " +
            Fmt("%.2f", params.max_baseline_direction_deviation_deg) +
            " deg): check the eye encoders, or the scene gave a wrong F");
  }
  ReportProgress(progress, {"done", 0, m.rms_sampson_px * m.rms_sampson_px, 1.0});
  return result;
}

stereo::Rectifier MakeRectifier(const CameraIntrinsics& cam0, const CameraIntrinsics& cam1,
                                const Eigen::Isometry3d& T_cam0_cam1,
                                stereo::CameraParameters* left, stereo::CameraParameters* right) {
  CheckCamera(cam0, "cam0");
  CheckCamera(cam1, "cam1");
  if (cam0.width != cam1.width || cam0.height != cam1.height) {
    throw CalibrationError(ErrorCode::kInvalidInput, "cam0 and cam1 must have the same size");
  }
  cv::Matx44d t01;
  for (int i = 0; i < 16; ++i) t01.val[i] = T_cam0_cam1.matrix()(i / 4, i % 4);
  stereo::CameraParameters l, r;
  // The body frame is cam0 itself: T_body_left = I, T_body_right = T_cam0_cam1.
  stereo::StereoRectifyFromExtrinsics(ToCv(cam0.k), cam0.distortion, ToCv(cam1.k), cam1.distortion,
                                      cv::Matx44d::eye(), t01, cv::Size(cam0.width, cam0.height),
                                      cam0.distortion_model, &l, &r);
  if (left) *left = l;
  if (right) *right = r;
  return stereo::Rectifier(l, r);
}

std::string StereoExtrinsicsModel::ToJson() const {
  json::Value root = json::Value::Object();
  root.Set("type", json::Value::String("stereo-extrinsics"));
  root.Set("format_version", json::Value::Number(1));
  const Eigen::Quaterniond q(T_cam0_cam1.linear());
  json::Value pose = json::Value::Object();
  pose.Set("p", json::Value::Numbers(T_cam0_cam1.translation().data(), 3));
  const double qv[4] = {q.w(), q.x(), q.y(), q.z()};
  pose.Set("q_wxyz", json::Value::Numbers(qv, 4));
  root.Set("T_cam0_cam1", std::move(pose));
  root.Set("rotation_deviation_deg", json::Value::Number(rotation_deviation_deg));
  root.Set("baseline_direction_deviation_deg",
           json::Value::Number(baseline_direction_deviation_deg));
  root.Set("inliers", json::Value::Number(inliers));
  root.Set("rms_sampson_px", json::Value::Number(rms_sampson_px));
  return json::Write(root);
}

StereoExtrinsicsModel StereoExtrinsicsModel::FromJson(std::string_view text) {
  try {
    const json::Value root = json::Parse(text);
    if (root.Get("type").AsString("type") != "stereo-extrinsics") {
      throw std::runtime_error("not a stereo-extrinsics model");
    }
    if (root.Get("format_version").AsNumber("format_version") != 1) {
      throw std::runtime_error("unsupported format_version");
    }
    StereoExtrinsicsModel m;
    const json::Value& pose = root.Get("T_cam0_cam1");
    const auto p = pose.Get("p").AsNumbers(3, "p");
    const auto q = pose.Get("q_wxyz").AsNumbers(4, "q_wxyz");
    const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
    if (std::abs(quat.norm() - 1.0) > 1e-6)
      throw std::runtime_error("q_wxyz is not a unit quaternion");
    m.T_cam0_cam1.linear() = quat.normalized().toRotationMatrix();
    m.T_cam0_cam1.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    m.rotation_deviation_deg =
        root.Get("rotation_deviation_deg").AsNumber("rotation_deviation_deg");
    m.baseline_direction_deviation_deg =
        root.Get("baseline_direction_deviation_deg").AsNumber("baseline_direction_deviation_deg");
    m.inliers = static_cast<int>(root.Get("inliers").AsNumber("inliers"));
    m.rms_sampson_px = root.Get("rms_sampson_px").AsNumber("rms_sampson_px");
    if (!m.T_cam0_cam1.matrix().allFinite()) throw std::runtime_error("non-finite pose");
    return m;
  } catch (const std::exception& e) {
    throw CalibrationError(ErrorCode::kInvalidInput,
                           std::string("cannot read stereo-extrinsics model: ") + e.what());
  }
}

double MedianRowOffset(const cv::Mat& rectified_left, const cv::Mat& rectified_right) {
  constexpr double kGrossMismatchPx = 20;
  std::vector<Eigen::Vector2d> pl, pr;
  MatchSift(rectified_left, rectified_right, 4000, 0.7, true, &pl, &pr);
  std::vector<double> dy;
  for (size_t i = 0; i < pl.size(); ++i) {
    const double d = std::abs(pl[i].y() - pr[i].y());
    if (d < kGrossMismatchPx) dy.push_back(d);
  }
  if (dy.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(dy.begin(), dy.end());
  const size_t n = dy.size();
  return n % 2 ? dy[n / 2] : 0.5 * (dy[n / 2 - 1] + dy[n / 2]);
}

double MedianRowOffset(const CameraIntrinsics& cam0, const CameraIntrinsics& cam1,
                       const Eigen::Isometry3d& T_cam0_cam1, const cv::Mat& left,
                       const cv::Mat& right) {
  cv::Mat rectified_left, rectified_right;
  MakeRectifier(cam0, cam1, T_cam0_cam1).Rectify(left, right, rectified_left, rectified_right);
  return MedianRowOffset(rectified_left, rectified_right);
}

}  // namespace epmap::calibration
