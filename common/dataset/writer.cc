#include "common/dataset/writer.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "common/imaging/pfm.h"

namespace epmap::dataset {

namespace fs = std::filesystem;

struct Writer::OpenCsv {
  std::string folder;
  std::FILE* file = nullptr;
};

Writer::Writer(const fs::path& root, bool overwrite) : root_(root), mav0_(root / "mav0") {
  if (fs::exists(root_)) {
    if (!fs::is_directory(root_)) {
      throw std::runtime_error(root_.string() + " exists and is not a folder");
    }
    if (!fs::is_empty(root_)) {
      if (!overwrite) {
        throw std::runtime_error(root_.string() +
                                 " exists and is not empty (use --force to replace it)");
      }
      for (const auto& entry : fs::directory_iterator(root_)) fs::remove_all(entry.path());
    }
  }
  fs::create_directories(mav0_);
}

Writer::~Writer() {
  for (auto& csv : csvs_) {
    if (csv->file) std::fclose(csv->file);
  }
}

std::FILE* Writer::Csv(const std::string& folder, const std::string& header) {
  for (auto& csv : csvs_) {
    if (csv->folder == folder) return csv->file;
  }
  const fs::path dir = folder.find('/') == std::string::npos ? mav0_ / folder : mav0_ / folder;
  fs::create_directories(dir.parent_path());
  fs::create_directories(dir);
  const fs::path path = dir / (folder == "gt_map" ? "walls.csv" : "data.csv");
  auto csv = std::make_unique<OpenCsv>();
  csv->folder = folder;
  csv->file = std::fopen(path.c_str(), "w");
  if (!csv->file) throw std::runtime_error("cannot write " + path.string());
  std::fprintf(csv->file, "%s\n", header.c_str());
  csvs_.push_back(std::move(csv));
  return csvs_.back()->file;
}

void Writer::WriteCameraSensor(int index, const CameraSensor& cam, const std::string& comment) {
  const fs::path dir = mav0_ / ("cam" + std::to_string(index));
  fs::create_directories(dir / "data");
  std::FILE* f = std::fopen((dir / "sensor.yaml").c_str(), "w");
  if (!f) throw std::runtime_error("cannot write " + (dir / "sensor.yaml").string());
  std::fprintf(f, "%%YAML:1.0\n# General sensor definitions.\nsensor_type: camera\ncomment: %s\n\n",
               comment.c_str());
  std::fprintf(f,
               "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n  cols: 4\n  rows: 4\n  data: [");
  for (int i = 0; i < 16; ++i) {
    std::fprintf(f, "%s%.12g", i ? ", " : "", cam.T_BS(i / 4, i % 4));
  }
  std::fprintf(f, "]\n\n# Camera specific definitions.\nrate_hz: %g\nresolution: [%d, %d]\n",
               cam.rate_hz, cam.width, cam.height);
  std::fprintf(f,
               "camera_model: pinhole\nintrinsics: [%.12g, %.12g, %.12g, %.12g] #fu, fv, cu, cv\n",
               cam.fu, cam.fv, cam.cu, cam.cv);
  std::fprintf(f, "distortion_model: %s\ndistortion_coefficients: [", cam.distortion_model.c_str());
  for (size_t i = 0; i < cam.distortion.size(); ++i) {
    std::fprintf(f, "%s%.12g", i ? ", " : "", cam.distortion[i]);
  }
  std::fprintf(f, "]\n");
  std::fclose(f);
}

void Writer::AddStereoFrame(int64_t stamp_ns, const cv::Mat& left, const cv::Mat& right) {
  const std::string name = std::to_string(stamp_ns) + ".png";
  for (int cam = 0; cam < 2; ++cam) {
    const std::string folder = "cam" + std::to_string(cam);
    std::FILE* csv = Csv(folder, "#timestamp [ns],filename");
    const fs::path file = mav0_ / folder / "data" / name;
    fs::create_directories(file.parent_path());
    if (!cv::imwrite(file.string(), cam == 0 ? left : right)) {
      throw std::runtime_error("cannot write " + file.string());
    }
    std::fprintf(csv, "%lld,%s\n", static_cast<long long>(stamp_ns), name.c_str());
  }
}

void Writer::SetJointNames(const std::vector<std::string>& names) {
  joint_names_ = names;
  const fs::path dir = mav0_ / "joints0";
  fs::create_directories(dir);
  std::ofstream y(dir / "sensor.yaml");
  y << "# Encoder readings of the kinematic chain in kinematics.urdf.\nsensor_type: joints\nnames: "
       "[";
  for (size_t i = 0; i < names.size(); ++i) y << (i ? ", " : "") << names[i];
  y << "]\nunits: rad\n";
}

void Writer::AddJoints(int64_t stamp_ns, const std::vector<double>& positions) {
  if (positions.size() != joint_names_.size()) {
    throw std::runtime_error("AddJoints: " + std::to_string(positions.size()) + " positions for " +
                             std::to_string(joint_names_.size()) + " names");
  }
  std::string header = "#timestamp [ns]";
  for (const auto& n : joint_names_) header += "," + n;
  std::FILE* csv = Csv("joints0", header);
  std::fprintf(csv, "%lld", static_cast<long long>(stamp_ns));
  for (double p : positions) std::fprintf(csv, ",%.9f", p);
  std::fprintf(csv, "\n");
}

void Writer::AddOdometry(const PlanarPose& pose) {
  std::FILE* csv = Csv("odometry0", "#timestamp [ns],x [m],y [m],theta [rad]");
  std::fprintf(csv, "%lld,%.6f,%.6f,%.6f\n", static_cast<long long>(pose.stamp_ns), pose.x, pose.y,
               pose.theta);
}

void Writer::WriteUrdf(const std::string& urdf_xml) {
  WriteFile("kinematics.urdf", urdf_xml);
}

void Writer::AddGtCameraPose(int64_t stamp_ns, const Eigen::Isometry3d& T_world_cam0) {
  std::FILE* csv =
      Csv("gt_camera_pose0", "#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w,q_x,q_y,q_z");
  const Eigen::Quaterniond q(T_world_cam0.linear());
  const Eigen::Vector3d t = T_world_cam0.translation();
  std::fprintf(csv, "%lld,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", static_cast<long long>(stamp_ns),
               t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
}

void Writer::AddGtBasePose(const PlanarPose& pose) {
  std::FILE* csv = Csv("gt_base_pose0", "#timestamp [ns],x [m],y [m],theta [rad]");
  std::fprintf(csv, "%lld,%.6f,%.6f,%.6f\n", static_cast<long long>(pose.stamp_ns), pose.x, pose.y,
               pose.theta);
}

void Writer::AddGtDisparity(int64_t stamp_ns, const cv::Mat& disparity) {
  std::FILE* csv = Csv("gt_disparity0", "#timestamp [ns],filename");
  const std::string name = std::to_string(stamp_ns) + ".pfm";
  fs::create_directories(mav0_ / "gt_disparity0" / "data");
  imaging::WritePfm(mav0_ / "gt_disparity0" / "data" / name, disparity);
  std::fprintf(csv, "%lld,%s\n", static_cast<long long>(stamp_ns), name.c_str());
}

void Writer::AddGtUnexpected(int64_t stamp_ns, const cv::Mat& mask) {
  std::FILE* csv = Csv("gt_unexpected0", "#timestamp [ns],filename");
  const std::string name = std::to_string(stamp_ns) + ".png";
  fs::create_directories(mav0_ / "gt_unexpected0" / "data");
  const fs::path file = mav0_ / "gt_unexpected0" / "data" / name;
  if (!cv::imwrite(file.string(), mask)) throw std::runtime_error("cannot write " + file.string());
  std::fprintf(csv, "%lld,%s\n", static_cast<long long>(stamp_ns), name.c_str());
}

void Writer::WriteWalls(const std::vector<WallSegment>& walls) {
  std::FILE* csv = Csv("gt_map", "x1 [m],y1 [m],x2 [m],y2 [m]");
  for (const auto& w : walls) std::fprintf(csv, "%.6f,%.6f,%.6f,%.6f\n", w.x1, w.y1, w.x2, w.y2);
}

fs::path Writer::WriteFile(const std::string& relative, const std::string& content) {
  const fs::path path = mav0_ / relative;
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << content;
  if (!out) throw std::runtime_error("cannot write " + path.string());
  return path;
}

}  // namespace epmap::dataset
