#pragma once
// A dataset's camera (common/dataset, the EuRoC-style sensor.yaml) as the intrinsics the stereo
// self-calibration takes. Header-only: the calibration library itself never reads datasets;
// its callers that do (benchmarks, tests) include this.

#include "common/dataset/dataset.h"
#include "perception/calibration/stereo_self_calibration.h"

namespace epmap::calibration {

inline CameraIntrinsics IntrinsicsOf(const dataset::CameraSensor& s) {
  CameraIntrinsics c;
  c.width = s.width;
  c.height = s.height;
  c.k << s.fu, 0, s.cu, 0, s.fv, s.cv, 0, 0, 1;
  c.distortion = s.distortion;
  c.distortion_model = s.distortion_model;
  return c;
}

}  // namespace epmap::calibration
