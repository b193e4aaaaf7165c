#pragma once
// Paper 003, Sec. II-III: the perceptual map. Views come one by one (the reference points of
// one stop, in the robot base frame, with the robot's pose estimate). Reference objects of the
// previous view are carried into the new view through the robot's motion (Eq. 5) and those
// near an object of the new view are the tracked ones (III-B). When fewer than a set number
// are still tracked, the previous view joins the global map (II step iii, III-C): each new
// object is placed by its vector from the nearest common tracked object, rotated by the
// accumulated turn, from that object's end point in the global map. The map is never updated
// or corrected afterwards (the model's premise). Redundancy removal and the boundary (III-D)
// are computed on demand.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "perception/perceptual_map/boundary.h"
#include "perception/perceptual_map/reference_objects.h"

namespace epmap::perceptual_map {

struct PerceptualMapParams {
  ClusteringParams clustering;
  // III-B: a transformed object of the previous view and an object of the new view are the
  // same when their lines are this close (each midpoint to the other segment) and this
  // parallel. The paper says "near" without a number.
  double track_max_distance_m = 0.3;
  double track_max_angle_rad = 0.35;  // 20 degrees
  // II step iii / III-C: the "pre-specified minimum number" of tracked reference objects.
  int min_tracked = 12;
  // III-C: the nearest common object is the anchor; among those nearby, prefer one whose
  // length in the view and in the global map agree to this ratio (same extent seen, so its end
  // point is the same physical point).
  double anchor_length_agreement = 0.7;
  double anchor_search_m = 3.0;  // a better-agreeing anchor may be this much farther away
  // A common object is an anchor only if its end points put the view within this distance of
  // where the robot's motion since the last map view puts it (0 = no check; no anchor left:
  // the view is placed by the motion). An end point that is not the same physical point in the
  // view and in the map (a wall cut elsewhere, seen shorter) shifts everything placed from it,
  // and every view placed after it. 0.3 m, the tracking's "near" (III-B): on four building
  // runs, mean wall coverage 45.8 -> 49.7 %, stray length 24.5 -> 18.0 %.
  double anchor_motion_tolerance_m = 0.3;
  // Place new objects by the robot's pose estimate instead of triangulating them from common
  // objects (III-C). Not the paper's model, which had only odometry: for a caller whose pose
  // is corrected otherwise (mobile_mapping::MobileMapper turns it on: paper 002's correction).
  bool place_by_pose = false;
  BoundaryParams boundary;
  void Validate() const;
};

// One view as the map keeps it.
struct MapView {
  uint32_t id = 0;
  int64_t stamp_ns = 0;
  Eigen::Isometry2d T_world_base = Eigen::Isometry2d::Identity();  // pose estimate given
  // Where the view sits in the map: heading from the accumulated turn, position anchored on
  // the common objects when the view joined the map (from the previous map view and the
  // motion otherwise).
  Eigen::Isometry2d T_map_base = Eigen::Isometry2d::Identity();
  uint32_t objects = 0;
  uint32_t tracked = 0;         // objects of this view tracked from the previous one
  bool in_map = false;          // joined the global map
  bool placed_by_pose = false;  // joined with no common object: placed by the motion alone
};

struct PerceptualMap {
  int64_t stamp_ns = 0;
  std::vector<MapSegment> segments;  // the global map (map frame = world = start pose)
  std::vector<MapView> views;
  std::vector<Eigen::Vector2d> path;      // view positions in the map frame
  Boundary boundary;                      // III-D over segments and path
  std::vector<MapSegment> kept_segments;  // the segments the boundary keeps (redundancy removed)
};

struct AddViewResult {
  uint32_t view_id = 0;
  size_t objects = 0;
  size_t tracked = 0;
  bool expanded = false;  // the previous view joined the global map
  bool skipped = false;   // the view had no reference object (nothing tracked, map untouched)
};

class PerceptualMapper {
 public:
  explicit PerceptualMapper(const PerceptualMapParams& params = {});

  // Adds a view: its reference points (x forward, y left, metres, in the base frame of the
  // view) and T_world_base, the pose estimate of the robot (odometry or corrected). The
  // pose's heading gives the accumulated turn (III-C); successive poses give the motion of
  // Eq. 5. Throws std::invalid_argument on a non-finite pose or stamps going backwards.
  AddViewResult AddView(int64_t stamp_ns, const std::vector<Eigen::Vector2d>& points_base,
                        const Eigen::Isometry2d& T_world_base);

  // The map now. With include_latest_view, the latest view is placed as if the map were
  // expanded now (without changing the mapper), so a planner also sees where the robot is.
  PerceptualMap Map(bool include_latest_view = true) const;

  // Reference objects of the latest view in its base frame (for pictures and tests).
  const std::vector<ReferenceObject>& latest_objects() const { return latest_.objects; }
  size_t views() const { return views_.size(); }
  // Segments of the global map (without the newest view's, which Map(true) adds): a count
  // that costs nothing, where Map() builds the boundary.
  size_t segments() const { return segments_.size(); }
  size_t skipped_views() const { return skipped_views_; }
  size_t expansions() const { return expansions_; }
  const PerceptualMapParams& params() const { return params_; }
  // Changes whenever what Map() returns may change (a view that was not blank, a restore), and
  // is never the same for two mappers built apart: a caller may keep Map()'s result while the
  // revision stays (the boundary, III-D, costs time that grows with the map and the path).
  // A copy has its original's revision, as it has its map.
  uint64_t revision() const { return revision_; }

  // Everything the mapper has built, for saving a map and resuming it (mobile_mapping's state).
  struct State {
    std::vector<MapSegment> segments;
    std::vector<MapView> views;
    bool has_latest = false;
    uint32_t latest_record = 0;                   // index into views of the newest view
    std::vector<ReferenceObject> latest_objects;  // its objects, in its base frame
    std::vector<int64_t> latest_global_id;        // per object: id in the global map, or -1
    uint64_t last_map_view = 0;                   // index into views of the last to join
    uint32_t next_id = 1;
    uint64_t skipped_views = 0;
    uint64_t expansions = 0;
    int64_t last_stamp_ns = 0;
  };
  State SavedState() const;
  // Takes over a saved state; throws std::invalid_argument (mapper unchanged) when its indices
  // or ids do not hold together or a coordinate is not finite.
  void Restore(State state);

 private:
  struct ViewState {
    uint32_t record = 0;  // index into views_
    std::vector<ReferenceObject> objects;
    std::vector<int64_t> global_id;  // per object: id in the global map, or -1
  };
  // Tracks prev's identified objects into cur through the motion (Eq. 5); returns the count.
  size_t Track(const ViewState& prev, ViewState* cur) const;
  // III-C: adds view's objects that are not yet in the map, returns their segments.
  void Expand(ViewState* view, std::vector<MapSegment>* segments, std::vector<MapView>* views,
              uint32_t* next_id, size_t last_map_view) const;

  PerceptualMapParams params_;
  std::vector<MapSegment> segments_;
  std::vector<MapView> views_;
  ViewState latest_;  // V_n, the newest view (V_{n-1} while the next one is tracked)
  bool has_latest_ = false;
  size_t last_map_view_ = 0;  // index into views_ of the last view that joined the map
  uint32_t next_id_ = 1;
  size_t skipped_views_ = 0;
  size_t expansions_ = 0;
  int64_t last_stamp_ns_ = 0;
  uint64_t revision_;
};

// Accumulated turn of a pose: the heading of its base x axis in the world frame.
double Heading(const Eigen::Isometry2d& T);

}  // namespace epmap::perceptual_map
