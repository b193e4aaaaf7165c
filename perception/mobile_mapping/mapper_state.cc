// MobileMapper::SaveState / RestoreState: the maps a service resumes after a restart.
//
// Format (version 2; version 1 is read too), little-endian, fixed-width fields in this order:
//   "EPMAPMAP" u32 version
//   camera: i32 width, height; f64 fx, fy, cx, cy, baseline
//   lattice: f64 resolution; u64 n; f64 layer bounds[n]
//   poses: u64 n; per record i64 stamp, iso2 odometry, iso2 corrected, u8 source, f64 visual and
//          odometry heading changes        (iso2 = f64 R00 R01 R10 R11 tx ty)
//   perceptual map: segments, views, the newest view's objects and ids, counters
//   grid: i64 min_ix, min_iy; i32 width, height; u64 layers; per layer u8 has_weights, then
//         the planes (empty, occupied, confidence[, hits, passes]) as f32 rows
//   counters (rejections by reason as u64-length strings), the correlation filter, the
//   panning flag, the last stamp
//   "END."
// Version 2 adds the heading turns after the counters and the heading filter (variance, the
// last stop's heading) after the correlation filter (MobileMapperParams::
// correlation_heading_step_rad); a version 1 state reads them as 0.
// A reader checks every length against what is left, so a truncated or foreign blob is a
// reason, never a crash or a half-restored mapper.

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "perception/mobile_mapping/mobile_mapper.h"

namespace epmap::mobile_mapping {

namespace {

static_assert(std::endian::native == std::endian::little,
              "the saved maps' format is little-endian; add byte swapping for this platform");

constexpr char kMagic[] = "EPMAPMAP";
constexpr char kEnd[] = "END.";
constexpr uint32_t kVersion = 2;
constexpr uint32_t kOldestVersion = 1;

class Writer {
 public:
  template <typename T>
  void Put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void Raw(const void* p, size_t n) { out_.append(static_cast<const char*>(p), n); }
  void Text(const std::string& s) {
    Put<uint64_t>(s.size());
    out_.append(s);
  }
  void Iso(const Eigen::Isometry2d& T) {
    const Eigen::Matrix2d R = T.linear();
    for (const double v :
         {R(0, 0), R(0, 1), R(1, 0), R(1, 1), T.translation().x(), T.translation().y()}) {
      Put(v);
    }
  }
  void Vec(const Eigen::Vector2d& v) {
    Put(v.x());
    Put(v.y());
  }
  void Plane(const cv::Mat& m) {
    for (int r = 0; r < m.rows; ++r) Raw(m.ptr<float>(r), sizeof(float) * m.cols);
  }
  std::string Take() { return std::move(out_); }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in) {}
  template <typename T>
  T Get() {
    static_assert(std::is_arithmetic_v<T>);
    T v;
    std::memcpy(&v, Take(sizeof(T)), sizeof(T));
    return v;
  }
  // A count of items of at least item_bytes each: more than the bytes left is a broken blob.
  size_t Count(size_t item_bytes) {
    const auto n = Get<uint64_t>();
    if (item_bytes > 0 && n > (in_.size() - pos_) / item_bytes) {
      throw std::runtime_error("a count of " + std::to_string(n) + " runs past the end");
    }
    return static_cast<size_t>(n);
  }
  std::string Text() {
    const size_t n = Count(1);
    return std::string(Take(n), n);
  }
  Eigen::Isometry2d Iso() {
    Eigen::Isometry2d T = Eigen::Isometry2d::Identity();
    Eigen::Matrix2d R;
    R(0, 0) = Get<double>();
    R(0, 1) = Get<double>();
    R(1, 0) = Get<double>();
    R(1, 1) = Get<double>();
    T.linear() = R;
    T.translation().x() = Get<double>();
    T.translation().y() = Get<double>();
    return T;
  }
  Eigen::Vector2d Vec() {
    const double x = Get<double>();
    return {x, Get<double>()};
  }
  cv::Mat Plane(int rows, int cols) {
    cv::Mat m(rows, cols, CV_32FC1);
    for (int r = 0; r < rows; ++r) {
      std::memcpy(m.ptr<float>(r), Take(sizeof(float) * cols), sizeof(float) * cols);
    }
    return m;
  }
  void Expect(std::string_view tag, const char* what) {
    if (std::string_view(Take(tag.size()), tag.size()) != tag) {
      throw std::runtime_error(std::string("no ") + what + " where it belongs");
    }
  }
  bool done() const { return pos_ == in_.size(); }

 private:
  const char* Take(size_t n) {
    if (n > in_.size() - pos_) throw std::runtime_error("the bytes end early (truncated?)");
    const char* p = in_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::string_view in_;
  size_t pos_ = 0;
};

bool Near(double a, double b) {
  return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(a));
}

// The header every state starts with: the format, then the camera the maps were made with.
// Throws std::runtime_error for another format or version.
stereo::RectifiedGeometry ReadHeader(Reader& r, uint32_t* version_out = nullptr) {
  r.Expect(std::string_view(kMagic, 8), "saved-maps header");
  const auto version = r.Get<uint32_t>();
  if (version < kOldestVersion || version > kVersion) {
    throw std::runtime_error("saved maps of format version " + std::to_string(version) +
                             ", this reads " + std::to_string(kOldestVersion) + " to " +
                             std::to_string(kVersion));
  }
  if (version_out) *version_out = version;
  stereo::RectifiedGeometry cam;
  cam.width = r.Get<int32_t>();
  cam.height = r.Get<int32_t>();
  cam.fx = r.Get<double>();
  cam.fy = r.Get<double>();
  cam.cx = r.Get<double>();
  cam.cy = r.Get<double>();
  cam.baseline_m = r.Get<double>();
  return cam;
}

}  // namespace

std::string MobileMapper::SaveState() const {
  Writer w;
  w.Raw(kMagic, 8);
  w.Put(kVersion);
  w.Put<int32_t>(camera_.width);
  w.Put<int32_t>(camera_.height);
  for (const double v :
       {camera_.fx, camera_.fy, camera_.cx, camera_.cy, camera_.baseline_m, grid_.resolution()}) {
    w.Put(v);
  }
  w.Put<uint64_t>(params_.grid.layer_bounds_m.size());
  for (const double b : params_.grid.layer_bounds_m) w.Put(b);

  w.Put<uint64_t>(poses_.records().size());
  for (const auto& r : poses_.records()) {
    w.Put(r.stamp_ns);
    w.Iso(r.T_world_base_odometry);
    w.Iso(r.T_world_base);
    w.Put(static_cast<uint8_t>(r.heading_source));
    w.Put(r.visual_dtheta);
    w.Put(r.odometry_dtheta);
  }

  const auto pm = perceptual_.SavedState();
  w.Put<uint64_t>(pm.segments.size());
  for (const auto& g : pm.segments) {
    w.Put(g.id);
    w.Vec(g.a);
    w.Vec(g.b);
    w.Put(g.view_id);
    w.Put(g.observations);
  }
  w.Put<uint64_t>(pm.views.size());
  for (const auto& v : pm.views) {
    w.Put(v.id);
    w.Put(v.stamp_ns);
    w.Iso(v.T_world_base);
    w.Iso(v.T_map_base);
    w.Put(v.objects);
    w.Put(v.tracked);
    w.Put<uint8_t>(v.in_map);
    w.Put<uint8_t>(v.placed_by_pose);
  }
  w.Put<uint8_t>(pm.has_latest);
  w.Put(pm.latest_record);
  w.Put<uint64_t>(pm.latest_objects.size());
  for (const auto& o : pm.latest_objects) {
    w.Vec(o.a);
    w.Vec(o.b);
    w.Put<int32_t>(o.point_count);
    w.Put(o.rms_m);
  }
  w.Put<uint64_t>(pm.latest_global_id.size());
  for (const int64_t id : pm.latest_global_id) w.Put(id);
  w.Put(pm.last_map_view);
  w.Put(pm.next_id);
  w.Put(pm.skipped_views);
  w.Put(pm.expansions);
  w.Put(pm.last_stamp_ns);

  w.Put(grid_.min_ix());
  w.Put(grid_.min_iy());
  w.Put<int32_t>(grid_.width());
  w.Put<int32_t>(grid_.height());
  w.Put<uint64_t>(grid_.planes().size());
  for (const auto& p : grid_.planes()) {
    const bool weights = !p.hits.empty();
    w.Put<uint8_t>(weights);
    if (grid_.empty()) continue;
    for (const cv::Mat* m : {&p.empty, &p.occupied, &p.confidence}) w.Plane(*m);
    if (weights) {
      w.Plane(p.hits);
      w.Plane(p.passes);
    }
  }

  const MapperCounters& c = counters_;
  w.Put(c.key_frames);
  w.Put(c.rejected);
  w.Put<uint64_t>(c.rejected_by_reason.size());
  for (const auto& [reason, n] : c.rejected_by_reason) {
    w.Text(reason);
    w.Put(n);
  }
  for (const uint64_t v :
       {c.groups, c.groups_too_short, c.views, c.views_without_objects, c.visual_heading,
        c.odometry_heading, c.registrations, c.shifts_applied, c.shifts_refused, c.heading_turns}) {
    w.Put(v);
  }
  w.Vec(filter_.variance);
  w.Put<uint8_t>(filter_.last_stop.has_value());
  w.Vec(filter_.last_stop.value_or(Eigen::Vector2d::Zero()));
  w.Put(filter_.heading_variance);
  w.Put(filter_.last_stop_heading);
  w.Put<uint8_t>(seen_panning_stop_);
  w.Put(last_stamp_ns_);
  w.Raw(kEnd, 4);
  return w.Take();
}

std::optional<stereo::RectifiedGeometry> MobileMapper::SavedCamera(std::string_view bytes,
                                                                   std::string* reason) {
  try {
    Reader r(bytes);
    return ReadHeader(r);
  } catch (const std::exception& e) {
    if (reason) *reason = std::string("the saved maps are not readable: ") + e.what();
    return std::nullopt;
  }
}

bool MobileMapper::RestoreState(std::string_view bytes, std::string* reason) {
  const auto refuse = [&](const std::string& why) {
    if (reason) *reason = why;
    return false;
  };
  if (!poses_.empty() || counters_.key_frames > 0 || group_.open) {
    return refuse("this mapper has already taken key frames");
  }
  try {
    Reader r(bytes);
    uint32_t version = 0;
    const stereo::RectifiedGeometry cam = ReadHeader(r, &version);
    if (cam.width != camera_.width || cam.height != camera_.height || !Near(cam.fx, camera_.fx) ||
        !Near(cam.fy, camera_.fy) || !Near(cam.cx, camera_.cx) || !Near(cam.cy, camera_.cy) ||
        !Near(cam.baseline_m, camera_.baseline_m)) {
      return refuse("the saved maps were made with another camera (" + std::to_string(cam.width) +
                    "x" + std::to_string(cam.height) + ", fx " + std::to_string(cam.fx) +
                    ", baseline " + std::to_string(cam.baseline_m) + " m)");
    }
    const auto resolution = r.Get<double>();
    std::vector<double> bounds(r.Count(sizeof(double)));
    for (auto& b : bounds) b = r.Get<double>();
    if (!Near(resolution, grid_.resolution()) ||
        bounds.size() != params_.grid.layer_bounds_m.size() ||
        !std::equal(bounds.begin(), bounds.end(), params_.grid.layer_bounds_m.begin(), Near)) {
      return refuse("the saved grid has another lattice (" + std::to_string(resolution) +
                    " m cells, " + std::to_string(bounds.size()) +
                    " height bounds): set maps.grid_resolution_m as it was, or start new maps");
    }

    std::vector<localisation::PoseRecord> records(r.Count(8 + 2 * 48 + 1 + 16));
    for (auto& p : records) {
      p.stamp_ns = r.Get<int64_t>();
      p.T_world_base_odometry = r.Iso();
      p.T_world_base = r.Iso();
      const auto source = r.Get<uint8_t>();
      if (source > static_cast<uint8_t>(localisation::HeadingSource::kOdometry)) {
        return refuse("a pose record has an unknown heading source");
      }
      p.heading_source = static_cast<localisation::HeadingSource>(source);
      p.visual_dtheta = r.Get<double>();
      p.odometry_dtheta = r.Get<double>();
    }

    perceptual_map::PerceptualMapper::State pm;
    pm.segments.resize(r.Count(4 + 32 + 8));
    for (auto& g : pm.segments) {
      g.id = r.Get<uint32_t>();
      g.a = r.Vec();
      g.b = r.Vec();
      g.view_id = r.Get<uint32_t>();
      g.observations = r.Get<uint32_t>();
    }
    pm.views.resize(r.Count(4 + 8 + 96 + 8 + 2));
    for (auto& v : pm.views) {
      v.id = r.Get<uint32_t>();
      v.stamp_ns = r.Get<int64_t>();
      v.T_world_base = r.Iso();
      v.T_map_base = r.Iso();
      v.objects = r.Get<uint32_t>();
      v.tracked = r.Get<uint32_t>();
      v.in_map = r.Get<uint8_t>() != 0;
      v.placed_by_pose = r.Get<uint8_t>() != 0;
    }
    pm.has_latest = r.Get<uint8_t>() != 0;
    pm.latest_record = r.Get<uint32_t>();
    pm.latest_objects.resize(r.Count(32 + 4 + 8));
    for (auto& o : pm.latest_objects) {
      o.a = r.Vec();
      o.b = r.Vec();
      o.point_count = r.Get<int32_t>();
      o.rms_m = r.Get<double>();
    }
    pm.latest_global_id.resize(r.Count(8));
    for (auto& id : pm.latest_global_id) id = r.Get<int64_t>();
    pm.last_map_view = r.Get<uint64_t>();
    pm.next_id = r.Get<uint32_t>();
    pm.skipped_views = r.Get<uint64_t>();
    pm.expansions = r.Get<uint64_t>();
    pm.last_stamp_ns = r.Get<int64_t>();

    const auto min_ix = r.Get<int64_t>();
    const auto min_iy = r.Get<int64_t>();
    const auto width = r.Get<int32_t>();
    const auto height = r.Get<int32_t>();
    if (width < 0 || height < 0 || width > 100000 || height > 100000) {
      return refuse("the saved grid's size is " + std::to_string(width) + " x " +
                    std::to_string(height));
    }
    std::vector<occupancy::LayeredGrid::LayerPlanes> planes(r.Count(1));
    for (auto& p : planes) {
      const bool weights = r.Get<uint8_t>() != 0;
      if (width == 0 || height == 0) continue;
      if (static_cast<uint64_t>(width) * static_cast<uint64_t>(height) * 4 * (weights ? 5 : 3) >
          bytes.size()) {
        return refuse("the saved grid's planes run past the end (truncated?)");
      }
      p.empty = r.Plane(height, width);
      p.occupied = r.Plane(height, width);
      p.confidence = r.Plane(height, width);
      if (weights) {
        p.hits = r.Plane(height, width);
        p.passes = r.Plane(height, width);
      }
    }

    MapperCounters c;
    c.key_frames = r.Get<uint64_t>();
    c.rejected = r.Get<uint64_t>();
    const size_t reasons = r.Count(16);
    for (size_t i = 0; i < reasons; ++i) {
      std::string name = r.Text();
      c.rejected_by_reason[std::move(name)] = r.Get<uint64_t>();
    }
    for (uint64_t* v :
         {&c.groups, &c.groups_too_short, &c.views, &c.views_without_objects, &c.visual_heading,
          &c.odometry_heading, &c.registrations, &c.shifts_applied, &c.shifts_refused}) {
      *v = r.Get<uint64_t>();
    }
    if (version >= 2) c.heading_turns = r.Get<uint64_t>();
    PositionFilter filter;
    filter.variance = r.Vec();
    const bool has_last_stop = r.Get<uint8_t>() != 0;
    const Eigen::Vector2d last_stop = r.Vec();
    if (has_last_stop) filter.last_stop = last_stop;
    if (version >= 2) {
      filter.heading_variance = r.Get<double>();
      filter.last_stop_heading = r.Get<double>();
    }
    const bool seen_panning_stop = r.Get<uint8_t>() != 0;
    const auto last_stamp_ns = r.Get<int64_t>();
    r.Expect(kEnd, "end mark");
    if (!r.done()) return refuse("bytes follow the end mark");
    if (!filter.variance.allFinite() || !last_stop.allFinite() ||
        !std::isfinite(filter.heading_variance) || filter.heading_variance < 0 ||
        !std::isfinite(filter.last_stop_heading)) {
      return refuse("the saved correlation filter is not finite");
    }

    // Every part checks itself before anything changes: build the parts aside, then swap.
    localisation::PoseCorrector poses(params_.pose);
    poses.Restore(std::move(records));
    perceptual_map::PerceptualMapper perceptual(params_.perceptual);
    perceptual.Restore(std::move(pm));
    occupancy::LayeredGrid grid(params_.grid);
    grid.RestorePlanes(min_ix, min_iy, width, height, std::move(planes));
    if (!poses.empty() && poses.latest().stamp_ns != last_stamp_ns) {
      return refuse("the saved poses end at another stamp than the saved maps");
    }
    poses_ = std::move(poses);
    perceptual_ = std::move(perceptual);
    grid_ = std::move(grid);
    counters_ = std::move(c);
    filter_ = filter;
    seen_panning_stop_ = seen_panning_stop;
    last_stamp_ns_ = last_stamp_ns;
    restore_unconfirmed_ = !poses_.empty();
    return true;
  } catch (const std::exception& e) {
    return refuse(std::string("the saved maps are not readable: ") + e.what());
  }
}

}  // namespace epmap::mobile_mapping
