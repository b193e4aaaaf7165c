// Eq. 4-7 and the pieces around them on exact synthetic projections: F_K from camera matrices
// equals K_R^-T [t]x R K_L^-1, the normalised 8-point algorithm, RANSAC with outliers, and the
// chirality test picking the right one of E's four decompositions.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "perception/calibration/stereo_self_calibration.h"
#include "perception/calibration/two_view_geometry.h"
#include "tests/support/head_urdf.h"

namespace epmap::calibration {
namespace {

struct Rig {
  Eigen::Matrix3d kl, kr;
  Eigen::Isometry3d T_cam0_cam1;                                             // cam1 in cam0
  Eigen::Matrix3d r() const { return T_cam0_cam1.inverse().linear(); }       // cam1 <- cam0
  Eigen::Vector3d t() const { return T_cam0_cam1.inverse().translation(); }  // cam1 <- cam0
};

Rig MakeRig(double vergence, double tilt) {
  Rig rig;
  rig.kl << 480, 0, 330, 0, 475, 238, 0, 0, 1;
  rig.kr << 490, 0, 318, 0, 488, 243, 0, 0, 1;
  rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  rig.T_cam0_cam1.translate(Eigen::Vector3d(0.068, 0.002, -0.001));
  rig.T_cam0_cam1.rotate(Eigen::AngleAxisd(-vergence, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()));
  return rig;
}

void Project(const Rig& rig, int n, double noise_px, uint64_t seed, std::vector<Eigen::Vector2d>* l,
             std::vector<Eigen::Vector2d>* r) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, noise_px);
  while (static_cast<int>(l->size()) < n) {
    const Eigen::Vector3d x(0.6 * u(rng), 0.45 * u(rng), 1.2 + 0.8 * u(rng));  // cam0 frame
    const Eigen::Vector3d xr = rig.r() * x + rig.t();
    const Eigen::Vector2d pl = (rig.kl * x).hnormalized() + Eigen::Vector2d(g(rng), g(rng));
    const Eigen::Vector2d pr = (rig.kr * xr).hnormalized() + Eigen::Vector2d(g(rng), g(rng));
    l->push_back(pl);
    r->push_back(pr);
  }
}

// F up to scale and sign.
double FDistance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::Matrix3d an = a / a.norm(), bn = b / b.norm();
  return std::min((an - bn).norm(), (an + bn).norm());
}

TEST(TwoViewGeometry, KinematicPriorFormulaEqualsTheExtrinsicForm) {
  for (double vergence : {0.0, 0.05, 0.2}) {
    const Rig rig = MakeRig(vergence, 0.01);
    CameraIntrinsics c0, c1;
    c0.k = rig.kl;
    c1.k = rig.kr;
    const Eigen::Matrix3d fk =
        FundamentalFromProjections(LeftCameraMatrix(c0), RightCameraMatrix(c1, rig.T_cam0_cam1));
    const Eigen::Matrix3d fe = FundamentalFromExtrinsics(rig.kl, rig.kr, rig.r(), rig.t());
    EXPECT_LT(FDistance(fk, fe), 1e-10) << vergence;
    // And it is the epipolar constraint of projected points, with the right orientation.
    std::vector<Eigen::Vector2d> l, r;
    Project(rig, 20, 0, 1, &l, &r);
    for (size_t i = 0; i < l.size(); ++i) EXPECT_LT(SampsonDistance(fk, l[i], r[i]), 1e-9);
  }
  // Two cameras at the same centre have no epipolar geometry.
  Matrix34d p = Matrix34d::Zero();
  p.leftCols<3>().setIdentity();
  EXPECT_THROW(FundamentalFromProjections(p, p), CalibrationError);
}

TEST(TwoViewGeometry, EightPointRecoversFFromExactAndNoisyMatches) {
  const Rig rig = MakeRig(0.08, 0.0);
  const Eigen::Matrix3d truth = FundamentalFromExtrinsics(rig.kl, rig.kr, rig.r(), rig.t());
  std::vector<Eigen::Vector2d> l, r;
  Project(rig, 8, 0, 2, &l, &r);
  EXPECT_LT(FDistance(EightPointFundamental(l, r), truth), 1e-8);
  l.clear();
  r.clear();
  Project(rig, 300, 0.3, 3, &l, &r);
  const Eigen::Matrix3d f = EightPointFundamental(l, r);
  double worst = 0;
  for (size_t i = 0; i < l.size(); ++i) worst = std::max(worst, SampsonDistance(f, l[i], r[i]));
  EXPECT_LT(worst, 2.0);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(f);
  const Eigen::Vector3d sv = svd.singularValues();
  EXPECT_LT(sv(2), 1e-12 * sv(0));  // rank 2
  EXPECT_THROW(EightPointFundamental({l.begin(), l.begin() + 7}, {r.begin(), r.begin() + 7}),
               CalibrationError);
}

TEST(TwoViewGeometry, RansacFindsTheInliersAmongOutliers) {
  const Rig rig = MakeRig(0.1, 0.02);
  std::vector<Eigen::Vector2d> l, r;
  Project(rig, 300, 0.2, 4, &l, &r);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 640);
  for (int i = 0; i < 300; i += 3) r[static_cast<size_t>(i)] = {u(rng), u(rng) * 0.75};  // 1/3
  const RansacResult res = RansacFundamental(l, r);
  int wrong = 0;
  for (int i = 0; i < 300; ++i) {
    const bool outlier = i % 3 == 0;
    // A random point can land on its epipolar line by chance; count only clear mistakes.
    if (!outlier && !res.inlier[static_cast<size_t>(i)]) ++wrong;
  }
  EXPECT_LE(wrong, 3);
  EXPECT_LE(res.inliers, 200 + 8);
  EXPECT_LT(FDistance(res.f, FundamentalFromExtrinsics(rig.kl, rig.kr, rig.r(), rig.t())), 0.02);
}

TEST(TwoViewGeometry, ChiralityPicksTheTrueDecomposition) {
  for (double vergence : {0.0, 0.1, -0.15}) {
    const Rig rig = MakeRig(vergence, 0.03);
    std::vector<Eigen::Vector2d> l, r;
    Project(rig, 50, 0, 6, &l, &r);
    std::vector<Eigen::Vector2d> nl, nr;
    for (size_t i = 0; i < l.size(); ++i) {
      nl.push_back((rig.kl.inverse() * l[i].homogeneous()).hnormalized());
      nr.push_back((rig.kr.inverse() * r[i].homogeneous()).hnormalized());
    }
    const Eigen::Matrix3d f = FundamentalFromExtrinsics(rig.kl, rig.kr, rig.r(), rig.t());
    const auto candidates = DecomposeEssential(EssentialFromFundamental(f, rig.kl, rig.kr), nl, nr);
    const RelativePose best = ChooseByChirality(candidates);
    EXPECT_EQ(best.in_front, 50);
    EXPECT_LT(RotationAngleDeg(best.r, rig.r()), 1e-6);
    EXPECT_LT(DirectionAngleDeg(best.t, rig.t()), 1e-6);
    int full = 0;
    for (const auto& c : candidates) full += c.in_front == 50 ? 1 : 0;
    EXPECT_EQ(full, 1) << "exactly one decomposition puts every point in front";
  }
}

TEST(TwoViewGeometry, HomographyExplainsAPlaneButNotDepth) {
  const Rig rig = MakeRig(0.05, 0.0);
  std::vector<Eigen::Vector2d> l, r;
  Project(rig, 200, 0.2, 7, &l, &r);
  const RansacResult depth = RansacHomography(l, r, 2.0, 500, 1);
  EXPECT_LT(depth.inliers, 100);
  // Points on the plane z = 1.5 in cam0.
  std::vector<Eigen::Vector2d> pl, pr;
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d x(0.6 * u(rng), 0.4 * u(rng), 1.5);
    pl.push_back((rig.kl * x).hnormalized());
    pr.push_back((rig.kr * (rig.r() * x + rig.t())).hnormalized());
  }
  EXPECT_EQ(RansacHomography(pl, pr, 2.0, 500, 1).inliers, 200);
}

TEST(TwoViewGeometry, KinematicPriorFromTheUrdf) {
  // The test head: the neck does not move one eye against the other, the eyes' joints do.
  auto chain = kinematics::UrdfChain::FromString(testing::kHeadUrdf);
  chain.BindJointOrder(
      {"eyes_tilt", "left_eye_pan", "right_eye_pan", "neck_pitch", "neck_roll", "neck_yaw"});
  const double vergence = 0.08;  // eyes turned towards each other
  const Eigen::Isometry3d prior =
      KinematicPrior(chain, {0.2, -vergence / 2, vergence / 2, 0.3, -0.2, 0.4});
  EXPECT_NEAR(prior.translation().norm(), 0.068, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(prior.linear()).angle(), vergence, 1e-12);
  // cam1 is to the right of cam0 (optical x points right), mostly along x.
  EXPECT_GT(prior.translation().x(), 0.067);
  EXPECT_THROW(KinematicPrior(chain, {0.1, std::nan(""), 0.0, 0.0, 0.0, 0.0}), CalibrationError);
}

}  // namespace
}  // namespace epmap::calibration
