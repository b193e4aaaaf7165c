#include "clients/sim/record.h"

#include <cstdio>
#include <initializer_list>
#include <string>

#include "common/dataset/writer.h"

namespace epmap::sim {

namespace {

std::string Stamp(int64_t ns) {
  return std::to_string(static_cast<long long>(ns));
}

std::string Csv(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.9f", v);
  return buf;
}

// Appends ",v1,v2,..." (GCC 12 warns falsely about `"," + std::string`, so append piecewise).
void AppendFields(std::string* line, std::initializer_list<double> values) {
  for (double v : values) line->append(",").append(Csv(v));
}

void RecordEyeHand(const Scenario& scenario, dataset::Writer& w) {
  // X_A as measured (with noise) in samples.csv; the same rows with the noise-free X_A in
  // gt_samples.csv.
  const std::string header = "#timestamp [ns],xa [m],ya [m],za [m],xb [m],yb [m],zb [m],path\n";
  std::string samples = header, truth = header;
  for (const auto& s : scenario.EyeHandSamples()) {
    for (auto [csv, xa] : {std::pair(&samples, s.xa), std::pair(&truth, s.xa_noise_free)}) {
      csv->append(Stamp(s.stamp_ns));
      AppendFields(csv, {xa.x(), xa.y(), xa.z(), s.xb.x(), s.xb.y(), s.xb.z()});
      csv->append(",").append(s.path).append("\n");
    }
  }
  w.WriteFile("samples.csv", samples);
  w.WriteFile("gt_samples.csv", truth);
  w.WriteUrdf(scenario.urdf());
}

}  // namespace

void Record(const Scenario& scenario, const std::filesystem::path& out, bool force,
            const RecordProgress& progress) {
  dataset::Writer w(out, force);
  if (scenario.frame_count() == 0) {
    RecordEyeHand(scenario, w);
    if (progress) progress(1, 1);
    return;
  }
  const std::string rig = "synthetic " + scenario.options().name + " rig (epmap-sim, seed " +
                          std::to_string(scenario.options().seed) + ")";
  w.WriteCameraSensor(0, scenario.cam0(), "left camera of the " + rig);
  w.WriteCameraSensor(1, scenario.cam1(), "right camera of the " + rig);
  w.WriteUrdf(scenario.urdf());
  w.WriteFile("gt_kinematics.urdf", scenario.true_urdf());
  const auto names = scenario.joint_names();
  w.SetJointNames(names);

  std::string gt_joints = "#timestamp [ns]";
  for (const auto& n : names) gt_joints.append(",").append(n);
  gt_joints += "\n";
  std::string gt_extrinsics = "#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w,q_x,q_y,q_z\n";
  std::string gt_movers = "#timestamp [ns],id,x [m],y [m],z [m]\n";

  const int total = scenario.frame_count();
  for (int i = 0; i < total; ++i) {
    const SimFrame f = scenario.Render(i);
    w.AddStereoFrame(f.stamp_ns, f.left, f.right);
    w.AddJoints(f.stamp_ns, f.joints);
    if (f.odometry) w.AddOdometry(*f.odometry);
    w.AddGtCameraPose(f.stamp_ns, f.gt_T_world_cam0);
    if (f.gt_base) w.AddGtBasePose(*f.gt_base);
    if (scenario.RecordsDisparity(f)) w.AddGtDisparity(f.stamp_ns, f.gt_disparity);
    if (scenario.has_moving_objects()) w.AddGtUnexpected(f.stamp_ns, f.gt_unexpected);
    for (size_t id = 0; id < f.gt_mover_centres.size(); ++id) {
      const Eigen::Vector3d& c = f.gt_mover_centres[id];
      gt_movers.append(Stamp(f.stamp_ns)).append(",").append(std::to_string(id + 1));
      AppendFields(&gt_movers, {c.x(), c.y(), c.z()});
      gt_movers.append("\n");
    }

    gt_joints.append(Stamp(f.stamp_ns));
    for (double q : f.gt_joints) gt_joints.append(",").append(Csv(q));
    gt_joints.append("\n");
    const Eigen::Quaterniond q(f.gt_T_cam0_cam1.linear());
    const Eigen::Vector3d p = f.gt_T_cam0_cam1.translation();
    gt_extrinsics.append(Stamp(f.stamp_ns));
    AppendFields(&gt_extrinsics, {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z()});
    gt_extrinsics.append("\n");
    if (progress) progress(i + 1, total);
  }
  w.WriteFile("gt_joints0/data.csv", gt_joints);
  w.WriteFile("gt_extrinsics0/data.csv", gt_extrinsics);
  if (scenario.has_moving_objects()) w.WriteFile("gt_movers0/data.csv", gt_movers);
  if (const auto walls = scenario.Walls(); !walls.empty()) w.WriteWalls(walls);
  if (const auto furniture = scenario.Furniture(); !furniture.empty()) {
    std::string csv = "x1 [m],y1 [m],x2 [m],y2 [m]\n";
    for (const auto& s : furniture) {
      char line[160];
      std::snprintf(line, sizeof(line), "%.6f,%.6f,%.6f,%.6f\n", s.x1, s.y1, s.x2, s.y2);
      csv.append(line);
    }
    w.WriteFile("gt_map/furniture.csv", csv);
  }
}

}  // namespace epmap::sim
