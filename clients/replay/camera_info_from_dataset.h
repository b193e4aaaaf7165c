#pragma once
// The CameraInfo a calibrated ROS stereo driver would publish for a dataset's two cameras:
// K and D from each sensor.yaml, R and P from stereo rectification of their relative pose
// (T_BS of both). Already-rectified rigs get R = I and P = K[I | t] with P_right[3] = -fx*B.

#include <utility>

#include "common/dataset/dataset.h"
#include "common/dds/ros_conversions.h"

namespace epmap::replay {

std::pair<dds::CameraCalibration, dds::CameraCalibration> CameraInfosFor(
    const dataset::Dataset& dataset);

}  // namespace epmap::replay
