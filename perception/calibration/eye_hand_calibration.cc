#include "perception/calibration/eye_hand_calibration.h"

namespace epmap::calibration {

EyeHandCalibrationResult CalibrateEyeHand(const std::vector<EyeHandSample>& train,
                                          const std::vector<EyeHandSample>& test,
                                          const EyeHandCalibrationParams& params,
                                          const ProgressCallback& progress) {
  ValidateSamples(train);
  ValidateSamples(test);
  if (train.empty()) {
    throw CalibrationError(ErrorCode::kDegenerate, "no training samples");
  }
  EyeHandCalibrationResult result;
  if (params.method == EyeHandMethod::kMixture) {
    MixtureFitResult fit = FitMixture(train, params.mixture, progress);
    result.model = std::move(fit.model);
    result.errors.outliers_rejected = fit.outliers_rejected;
    result.errors.experts = static_cast<int>(result.model.experts().size());
    result.cross_validation = std::move(fit.cross_validation);
    std::vector<EyeHandSample> inliers;
    for (size_t i = 0; i < train.size(); ++i) {
      if (fit.inlier[i]) inliers.push_back(train[i]);
    }
    result.errors.train_inliers = EvaluateModel(result.model, inliers);
  } else {
    Se3FitParams p = params.se3;
    p.anisotropic_scale = params.method == EyeHandMethod::kSe3Scale;
    const Se3FitResult fit = FitSe3(PointsA(train), PointsB(train), p, progress);
    result.model = EyeHandModel(params.method, {fit.transform});
    result.errors.outliers_rejected = fit.stats.rejected;
    result.errors.train_inliers = fit.stats.inlier_errors;
  }
  result.errors.initial = EvaluateUncalibrated(test.empty() ? train : test);
  result.errors.train = EvaluateModel(result.model, train);
  result.errors.test = EvaluateModel(result.model, test);
  return result;
}

}  // namespace epmap::calibration
