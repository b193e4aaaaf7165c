// MapService's mobile-base RPCs (issue 6): the perceptual map, the occupancy grid and the pose
// from the newest snapshot's maps (services/mapping/pipeline/pipeline_maps.cc). Errors:
// FAILED_PRECONDITION when the service is not in mobile-base mode or no key frame has made a
// map yet, INVALID_ARGUMENT for a layer the grid does not have, a max_height_m below its lowest
// band, or both at once, a window (of either map) that is no box, a grid window larger than the
// message limit, DEADLINE_EXCEEDED when no maps newer than newer_than_ns came within wait_ms.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include <spdlog/fmt/fmt.h>

#include "perception/perceptual_map/map_window.h"
#include "services/mapping/api/map_service.h"
#include "services/mapping/service.h"

namespace epmap::mapping {

namespace {

void ToProto(const Eigen::Isometry2d& T, v1::Pose2D* out) {
  out->set_x(T.translation().x());
  out->set_y(T.translation().y());
  out->set_theta(std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
}

void ToProto(const Eigen::Vector2d& p, v1::Point2D* out) {
  out->set_x(p.x());
  out->set_y(p.y());
}

// A window of the maps (GetOccupancyGridRequest / GetPerceptualMapRequest region or
// around_robot_m), as both requests spell it.
struct WindowRequest {
  const v1::GridRegion* region = nullptr;
  std::optional<double> around_robot_m;

  template <class Request>
  static WindowRequest Of(const Request& request) {
    WindowRequest w;
    if (request.has_region()) w.region = &request.region();
    if (request.has_around_robot_m()) w.around_robot_m = request.around_robot_m();
    return w;
  }
  bool asked() const { return region || around_robot_m; }
};

// What can be checked before there is a map to look at.
grpc::Status CheckWindowRequest(const WindowRequest& request) {
  if (request.region && request.around_robot_m) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "give a region or around_robot_m, not both (a region is a box in the world frame; "
            "around_robot_m a square centred on the robot)"};
  }
  if (request.around_robot_m &&
      !(*request.around_robot_m > 0 && std::isfinite(*request.around_robot_m))) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            fmt::format("around_robot_m {} must be a positive number of metres (the side of "
                        "the square around the robot)",
                        *request.around_robot_m)};
  }
  if (request.region) {
    const auto& b = *request.region;
    if (!std::isfinite(b.min_x()) || !std::isfinite(b.min_y()) || !std::isfinite(b.max_x()) ||
        !std::isfinite(b.max_y()) || !(b.min_x() < b.max_x()) || !(b.min_y() < b.max_y())) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              fmt::format("region [{}, {}] x [{}, {}] m must be finite with min_x < max_x and "
                          "min_y < max_y",
                          b.min_x(), b.max_x(), b.min_y(), b.max_y())};
    }
  }
  return grpc::Status::OK;
}

// The window's box in the world frame on these maps (a checked request that asked for one).
grpc::Status WindowBoxOf(const WindowRequest& request, const mobile_mapping::MapsSnapshot& maps,
                         Eigen::AlignedBox2d* box) {
  if (request.region) {
    const auto& b = *request.region;
    *box = Eigen::AlignedBox2d(Eigen::Vector2d(b.min_x(), b.min_y()),
                               Eigen::Vector2d(b.max_x(), b.max_y()));
    return grpc::Status::OK;
  }
  if (maps.poses.empty()) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "no pose yet to centre the window on (no key frame has been accepted)"};
  }
  // The corrected pose of the same key frame as the maps: no race with a separate GetPose.
  const Eigen::Vector2d at = maps.poses.back().T_world_base.translation();
  const Eigen::Vector2d half = Eigen::Vector2d::Constant(*request.around_robot_m / 2);
  *box = Eigen::AlignedBox2d(at - half, at + half);
  return grpc::Status::OK;
}

// The grid window asked for on these maps' lattice (nullopt: none asked for), refused when it
// would not fit in a message of max_message_mb (2 bytes a cell, and room for the rest).
grpc::Status GridWindowOf(const WindowRequest& request, const mobile_mapping::MapsSnapshot& maps,
                          int max_message_mb, std::optional<occupancy::CellWindow>* window) {
  window->reset();
  if (!request.asked()) return grpc::Status::OK;
  Eigen::AlignedBox2d box;
  if (auto bad = WindowBoxOf(request, maps, &box); !bad.ok()) return bad;
  const double min_x = box.min().x(), min_y = box.min().y();
  const double max_x = box.max().x(), max_y = box.max().y();
  try {
    *window = occupancy::WindowOverBox(maps.grid.resolution(), min_x, min_y, max_x, max_y);
  } catch (const std::invalid_argument& e) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            fmt::format("region [{}, {}] x [{}, {}] m: {}", min_x, max_x, min_y, max_y, e.what())};
  }
  const size_t max_cells = ((static_cast<size_t>(max_message_mb) << 20) - (64U << 10)) / 2;
  if ((*window)->cells() > max_cells) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            fmt::format("the window is {} x {} cells of {} m; api.max_message_mb {} allows {} "
                        "cells (2 bytes each): ask for a smaller one",
                        (*window)->width, (*window)->height, maps.grid.resolution(), max_message_mb,
                        max_cells)};
  }
  return grpc::Status::OK;
}

}  // namespace

grpc::Status MapServiceImpl::LatestMaps(grpc::ServerContext* context, int64_t newer_than_ns,
                                        uint32_t wait_ms,
                                        std::shared_ptr<const mobile_mapping::MapsSnapshot>* maps) {
  if (auto bad = CheckWait(newer_than_ns, wait_ms); !bad.ok()) return bad;
  // Right after a restart the maps resumed from the state dir are served as saved until the
  // first frames come (even before odometry makes an `auto` service a mobile base again).
  if (const auto resumed = service_.pipeline().ResumedMapsBeforeFirstFrame();
      resumed && resumed->stamp_ns > newer_than_ns) {
    const auto latest = service_.snapshots().Latest();
    if (!latest || !latest->maps) {
      *maps = resumed;
      return grpc::Status::OK;
    }
  }
  const auto not_mobile = [&](const std::string& mode) {
    return grpc::Status{grpc::StatusCode::FAILED_PRECONDITION,
                        "the maps are built in mobile-base mode only; the service is in '" + mode +
                            "' mode (mobile-base needs odometry on " +
                            service_.config().topics.odom + " or robot.mode: mobile-base)"};
  };
  // An `auto` service becomes a mobile base when odometry arrives: worth waiting for.
  const std::string mode = service_.pipeline().mode();
  if (mode != "mobile-base" && (wait_ms == 0 || service_.config().mode != "auto")) {
    return not_mobile(mode);
  }
  if (!service_.config().maps.enabled) {
    return {grpc::StatusCode::FAILED_PRECONDITION, "the maps are disabled (maps.enabled: false)"};
  }
  // A planner that has the maps of newer_than_ns waits for the next key frame's; maps change
  // only at key frames, so most snapshots in between carry the same ones.
  const auto snapshot = WaitForSnapshot(context, wait_ms, [&](const MapSnapshot& s) {
    return s.maps && s.maps->stamp_ns > newer_than_ns;
  });
  if (!snapshot || !snapshot->maps) {
    if (const std::string now = service_.pipeline().mode(); now != "mobile-base") {
      return not_mobile(now);
    }
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "no map yet: no key frame has been accepted (see GetStatus "
            "key_frames_refused_by_reason for refused ones)"};
  }
  if (snapshot->maps->stamp_ns <= newer_than_ns) {
    return {grpc::StatusCode::DEADLINE_EXCEEDED,
            "no maps newer than the requested stamp within wait_ms (they change at key frames: "
            "when the base moves or the head pans)"};
  }
  *maps = snapshot->maps;
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::GetPerceptualMap(grpc::ServerContext* context,
                                              const v1::GetPerceptualMapRequest* request,
                                              v1::PerceptualMap* out) {
  const auto window = WindowRequest::Of(*request);
  if (auto bad = CheckWindowRequest(window); !bad.ok()) return bad;
  std::shared_ptr<const mobile_mapping::MapsSnapshot> maps;
  if (auto status = LatestMaps(context, request->newer_than_ns(), request->wait_ms(), &maps);
      !status.ok()) {
    return status;
  }
  std::optional<Eigen::AlignedBox2d> box;
  if (window.asked()) {
    box.emplace();
    if (auto bad = WindowBoxOf(window, *maps, &*box); !bad.ok()) return bad;
  }
  const auto& m = maps->perceptual();
  out->set_stamp_ns(maps->stamp_ns);
  out->set_includes_open_stop(maps->includes_open_stop);
  out->set_resumed_unconfirmed(maps->resumed_unconfirmed);
  out->set_segments_in_map(static_cast<uint32_t>(m.segments.size()));
  out->set_window(box.has_value());
  std::unordered_set<uint32_t> kept;  // paper 003 III-D's redundancy removal
  for (const auto& s : m.kept_segments) kept.insert(s.id);
  std::unordered_map<uint32_t, uint32_t> segments_of_view;
  for (const auto& s : m.segments) {
    ++segments_of_view[s.view_id];
    const bool is_kept = kept.count(s.id) > 0;
    if (request->kept_only() && !is_kept) continue;
    if (box && !perceptual_map::SegmentTouchesBox(s.a, s.b, *box)) continue;
    auto* seg = out->add_segments();
    seg->set_kept(is_kept);
    seg->set_id(s.id);
    seg->set_x1(s.a.x());
    seg->set_y1(s.a.y());
    seg->set_x2(s.b.x());
    seg->set_y2(s.b.y());
    seg->set_view_id(s.view_id);
    seg->set_observations(s.observations);
  }
  for (const auto& v : m.views) {
    if (!v.in_map) continue;  // views that only tracked objects added nothing to the map
    auto* view = out->add_views();
    view->set_id(v.id);
    view->set_stamp_ns(v.stamp_ns);
    ToProto(v.T_map_base, view->mutable_pose());
    view->set_segments(segments_of_view[v.id]);  // of the whole map, window or not
  }
  for (const auto& p : m.path) ToProto(p, out->add_path());
  for (const auto& p : m.boundary.outer) ToProto(p, out->add_boundary());
  for (const auto& p : m.boundary.inner) ToProto(p, out->add_inner_boundary());
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::GetOccupancyGrid(grpc::ServerContext* context,
                                              const v1::GetOccupancyGridRequest* request,
                                              v1::OccupancyGrid* out) {
  if (request->has_layer() && request->has_max_height_m()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "give a layer or max_height_m, not both (a layer is one band; max_height_m combines "
            "the bands a robot that tall can hit)"};
  }
  const auto window_request = WindowRequest::Of(*request);
  if (auto bad = CheckWindowRequest(window_request); !bad.ok()) return bad;
  std::shared_ptr<const mobile_mapping::MapsSnapshot> maps;
  if (auto status = LatestMaps(context, request->newer_than_ns(), request->wait_ms(), &maps);
      !status.ok()) {
    return status;
  }
  std::optional<occupancy::CellWindow> window;
  if (auto bad = GridWindowOf(window_request, *maps, service_.config().max_message_mb, &window);
      !bad.ok()) {
    return bad;
  }
  const int layers = maps->grid.layer_count();
  std::optional<int> layer;
  int first_layers = layers;  // the combined map's bands, from the floor up
  if (request->has_layer()) {
    if (request->layer() >= static_cast<uint32_t>(layers)) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              "layer " + std::to_string(request->layer()) + " does not exist: the grid has " +
                  std::to_string(layers) + " height bands (layers 0.." +
                  std::to_string(layers - 1) + "); omit the layer for the combined map"};
    }
    layer = static_cast<int>(request->layer());
  }
  if (request->has_max_height_m()) {
    first_layers = maps->grid.LayersBelow(request->max_height_m());
    if (first_layers == 0) {
      const double floor_m = maps->grid.params().layer_bounds_m.front();
      return {grpc::StatusCode::INVALID_ARGUMENT,
              fmt::format("max_height_m {} must be a number above the lowest band's floor, {} m "
                          "above the floor (below it the grid has nothing to hit)",
                          request->max_height_m(), floor_m)};
    }
  }
  const occupancy::GridExport g =
      window ? (layer ? maps->grid.ExportWindow(*window, layer)
                      : maps->grid.ExportBelowWindow(*window, first_layers))
             : (layer ? maps->grid.Export(layer) : maps->grid.ExportBelow(first_layers));
  if (window ? maps->grid.empty() : g.width == 0 || g.height == 0) {
    // A stop's points join the grid once the stop would make a view (provisionally while the
    // base stands, for good when it moves on); an empty map is no map.
    return {grpc::StatusCode::FAILED_PRECONDITION,
            std::string(layer ? "layer " + std::to_string(*layer) + " of the" : "the") +
                " occupancy grid has no known cell yet (a stop joins it once it makes a view: "
                "provisionally while the base stands there, for good when it moves on)"};
  }
  out->set_stamp_ns(maps->stamp_ns);
  out->set_includes_open_stop(maps->includes_open_stop);
  out->set_resumed_unconfirmed(maps->resumed_unconfirmed);
  out->set_resolution_m(g.resolution_m);
  out->mutable_origin()->set_x(g.origin_x);
  out->mutable_origin()->set_y(g.origin_y);
  out->mutable_origin()->set_theta(0.0);
  out->set_width(g.width);
  out->set_height(g.height);
  out->set_layer_count(g.layer_count);
  for (double b : g.layer_bounds_m) out->add_layer_bounds_m(b);
  out->set_combined(g.combined);
  out->set_layer(g.layer);
  out->set_combined_layers(g.combined_layers);
  out->set_window(window.has_value());
  out->set_occupancy(g.occupancy.data(), g.occupancy.size());
  out->set_confidence(g.confidence.data(), g.confidence.size());
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::ResetMaps(grpc::ServerContext*, const v1::ResetMapsRequest*,
                                       v1::ResetMapsResponse* out) {
  if (!service_.config().maps.enabled) {
    return {grpc::StatusCode::FAILED_PRECONDITION, "the maps are disabled (maps.enabled: false)"};
  }
  if (const auto latest = service_.snapshots().Latest(); latest && latest->maps) {
    out->set_key_frames_dropped(latest->maps->counters.key_frames);
  } else if (const auto resumed = service_.pipeline().ResumedMapsBeforeFirstFrame()) {
    out->set_key_frames_dropped(resumed->counters.key_frames);
  }
  try {
    out->set_saved_maps_cleared(service_.pipeline().RequestMapsReset());
  } catch (const std::exception& e) {
    return {grpc::StatusCode::INTERNAL,
            std::string("the saved maps could not be cleared: ") + e.what()};
  }
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::GetPose(grpc::ServerContext* context,
                                     const v1::GetPoseRequest* request, v1::PoseEstimate* out) {
  std::shared_ptr<const mobile_mapping::MapsSnapshot> maps;
  if (auto status = LatestMaps(context, request->newer_than_ns(), request->wait_ms(), &maps);
      !status.ok()) {
    return status;
  }
  if (maps->poses.empty()) {
    return {grpc::StatusCode::FAILED_PRECONDITION, "no pose yet: no key frame accepted"};
  }
  const auto& r = maps->poses.back();
  out->set_stamp_ns(r.stamp_ns);
  ToProto(r.T_world_base_odometry, out->mutable_odometry());
  ToProto(r.T_world_base, out->mutable_corrected());
  // corrected - odometry, component-wise in the world frame, the angle wrapped to (-pi, pi].
  const auto& o = out->odometry();
  const auto& c = out->corrected();
  double dtheta = std::remainder(c.theta() - o.theta(), 2.0 * std::numbers::pi);
  if (dtheta <= -std::numbers::pi) dtheta += 2.0 * std::numbers::pi;
  out->mutable_difference()->set_x(c.x() - o.x());
  out->mutable_difference()->set_y(c.y() - o.y());
  out->mutable_difference()->set_theta(dtheta);
  out->set_keyframes(static_cast<uint32_t>(maps->counters.key_frames));
  out->set_registrations(static_cast<uint32_t>(maps->counters.registrations));
  out->set_resumed_unconfirmed(maps->resumed_unconfirmed);
  return grpc::Status::OK;
}

}  // namespace epmap::mapping
