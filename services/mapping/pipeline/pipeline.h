#pragma once
// The pipeline thread: takes assembled stereo frames from the queue, rectifies them (from
// CameraInfo or the configured camera), finds the camera pose (URDF chain + joints, or
// odometry), computes the disparity and publishes an immutable snapshot.

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "perception/ep/expected_perception.h"
#include "perception/internal_model/pose_source.h"
#include "perception/kinematics/urdf_chain.h"
#include "perception/mobile_mapping/key_frame_selector.h"
#include "perception/mobile_mapping/mobile_mapper.h"
#include "perception/stereo/rectification.h"
#include "perception/stereo/sgbm.h"
#include "services/mapping/calibration/active_models.h"
#include "services/mapping/calibration/frame_tap.h"
#include "services/mapping/calibration/model_rectification.h"
#include "services/mapping/config/service_config.h"
#include "services/mapping/ingest/bounded_queue.h"
#include "services/mapping/ingest/dds_ingest.h"
#include "services/mapping/ingest/sensor_state.h"
#include "services/mapping/maps_store/maps_store.h"
#include "services/mapping/pipeline/map_snapshot.h"
#include "services/mapping/pipeline/stage_stats.h"
#include "services/mapping/pipeline/unexpected_events.h"

namespace epmap::mapping {

class Pipeline {
 public:
  // Throws std::runtime_error if the configured URDF cannot be loaded.
  Pipeline(const ServiceConfig& config, BoundedQueue<StereoFrame>& queue, SensorState& sensors,
           IngestCounters& counters, SnapshotStore& snapshots);
  ~Pipeline();

  void Start();
  void Stop();  // finishes the frame in hand, then returns

  uint64_t frames_processed() const { return processed_.load(); }
  const RollingStats& stage_ms() const { return *stage_ms_; }
  const RollingStats& figures() const { return figures_; }  // latency_ms, recomputed_share
  uint64_t full_refreshes() const { return full_refreshes_.load(); }
  CounterSet& events() { return events_; }
  std::string mode() const;
  // Every frame's unexpected regions, for WatchUnexpected streams.
  UnexpectedEventHub& unexpected_hub() { return unexpected_hub_; }
  // The internal model in use: urdf, learned, odometry or fixed.
  std::string EffectivePoseSource() const;
  // The kinematic chain of robot.urdf, or nullptr without one (read-only after construction).
  const kinematics::UrdfChain* chain() const { return chain_ ? &*chain_ : nullptr; }

  // Calibration (services/mapping/calibration; pipeline_calibration.cc): the models the
  // pipeline applies (an active stereo-extrinsics model replaces CameraInfo's R, P) and the tap
  // through which stereo-extrinsics jobs see raw frames. Call before Start().
  void AttachCalibration(const ActiveModels* models, RawFrameTap* tap,
                         double rectification_rebuild_deg);

  // ResetMaps (any thread): the saved maps are cleared now, the maps in memory at the next
  // frame (or at Stop). Returns whether there were durable maps to clear; throws
  // std::runtime_error when they could not be cleared.
  bool RequestMapsReset();
  // The maps resumed from the state dir at start-up, while no key frame has been accepted yet
  // (then the snapshots carry them): a planner asking right after a restart gets the maps as
  // saved (MapsSnapshot::resumed_unconfirmed), not "no map yet". Null otherwise (any thread).
  std::shared_ptr<const mobile_mapping::MapsSnapshot> ResumedMapsBeforeFirstFrame() const;
  // The durable maps' store (maps.persist with state.dir), or nullptr: set at construction,
  // thread-safe.
  const MapsStore* maps_store() const { return maps_store_.get(); }

 private:
  void Run();
  void Process(StereoFrame& frame);
  // The rectifier for the current calibration; nullptr (and a counted rejection) if none.
  const stereo::Rectifier* CurrentRectifier(const StereoFrame& frame);
  // The raw (unrectified) cam0 pose in the base frame at a stamp, from the internal model, and
  // on a mobile base the base's pose in the odometry frame; nullopt with *reason when their
  // inputs are missing (pipeline_ep.cc).
  std::optional<FramePose> PoseAt(int64_t stamp_ns, std::string* reason);
  void SetUpPoseSource();
  // Says once (log and status event) when the left images name another camera frame than the
  // URDF's left camera link: tf consumers then see the disparity and the poses in two frames.
  void WarnOnceIfTheImagesAreNotInTheUrdfCameraFrame(const std::string& image_frame_id);
  // The same for rt/odom (mobile base): its frame should be maps.odom_frame (the child of the
  // map -> odom transform on rt/tf). Its child frame is checked by ComposesThroughTheUrdf.
  void WarnOnceIfTheOdometryIsNotInTheConfiguredFrames();
  // The URDF root's planar pose in the odometry frame from an rt/odom reading: the reading
  // itself when rt/odom moves the root (or a frame the URDF does not have: warned once), composed
  // through the URDF when it moves another of its links (e.g. base_link under base_footprint).
  // `joints` in chain_->joint_names() order.
  Eigen::Isometry3d UrdfRootOnOdometry(const dds::PlanarOdometry& odom,
                                       const std::vector<double>& joints);
  // Whether rt/odom's moving frame `child` is a link the root's pose can be composed from (not
  // the root itself); says once what it decided when that is not the plain root. Needs chain_.
  bool ComposesThroughTheUrdf(const std::string& child);
  // A warning logged, and counted as status event `event`, the first time only.
  void WarnOnce(const std::string& event, const std::string& message);
  // The same at info level, for what is handled but worth one line in the log.
  void NoteOnce(const std::string& event, const std::string& message);
  // The EP map of this frame into the snapshot (pipeline_ep.cc).
  void RunExpectedPerception(const StereoFrame& frame, const stereo::Rectifier& rectifier,
                             const cv::Mat& left, const cv::Mat& right,
                             const std::optional<FramePose>& raw_pose,
                             const std::string& pose_reason, MapSnapshot& snapshot);
  // Mobile-base mode: hands key frames to the mobile mapper and puts its maps into the
  // snapshot (pipeline_maps.cc).
  void RunMaps(const StereoFrame& frame, const stereo::Rectifier& rectifier, const cv::Mat& left,
               const cv::Mat& right, MapSnapshot& snapshot);
  // Durable maps (pipeline_maps.cc). OpenMapsStore, then ResumeSavedMaps: at construction,
  // mapper_ is made for the saved maps' camera and takes them over (served at once, see
  // ResumedMapsBeforeFirstFrame; ForgetResumedMaps when the snapshots take over or the maps
  // go). SaveMaps: hands the maps to the store
  // when a stop joined them since the last save (and, unless `now_regardless`, save_period_s
  // has passed). ApplyMapsReset: drops the maps in memory if a reset was asked for (pipeline
  // thread, or after it stopped).
  void OpenMapsStore();
  void ResumeSavedMaps();
  void ForgetResumedMaps();
  void SaveMaps(bool now_regardless);
  void ApplyMapsReset();
  // The rectifier under the active stereo model, or nullptr (with a counted rejection); only
  // called when a stereo model is active (pipeline_calibration.cc).
  const stereo::Rectifier* StereoModelRectifier(const StereoFrame& frame,
                                                const ActiveModels::Stereo& model);

  const ServiceConfig config_;
  BoundedQueue<StereoFrame>& queue_;
  SensorState& sensors_;
  IngestCounters& counters_;
  SnapshotStore& snapshots_;

  std::optional<kinematics::UrdfChain> chain_;
  std::set<std::string> warned_;  // WarnOnce's events so far (pipeline thread only)
  // rt/odom's moving frame as UrdfRootOnOdometry last resolved it (pipeline thread only).
  struct OdometryChild {
    std::string name;
    bool composed = false;  // the root's pose is composed through the URDF from this link
  };
  std::optional<OdometryChild> odometry_child_;
  std::string pose_source_;  // as configured (auto resolves per frame)
  std::optional<internal_model::LearnedPoseSource> learned_;
  std::vector<std::string> learned_inputs_;
  stereo::SgbmMatcher matcher_;  // full-frame SGBM when EP is disabled
  ep::EpParams ep_params_;
  std::unique_ptr<ep::ExpectedPerception> ep_;
  UnexpectedEventHub unexpected_hub_;
  std::optional<stereo::Rectifier> rectifier_;
  uint64_t rectifier_version_ = ~0ull;

  // Maps of the mobile base (pipeline_maps.cc): created at the first key frame, or at
  // construction when saved maps are resumed.
  std::unique_ptr<mobile_mapping::MobileMapper> mapper_;
  std::optional<mobile_mapping::KeyFrameSelector> key_frames_;
  std::vector<mobile_mapping::JointLimit> joint_limits_;  // of the chain's joints, from the URDF
  std::shared_ptr<const mobile_mapping::MapsSnapshot> maps_;
  // Durable maps (maps.persist with state.dir; pipeline_maps.cc): opened at construction (set
  // once, then shared with RequestMapsReset and GetStatus); what it holds is resumed into
  // mapper_ then too, and served from resumed_maps_ until the snapshots carry maps.
  std::unique_ptr<MapsStore> maps_store_;
  mutable std::mutex resumed_maps_mutex_;
  std::shared_ptr<const mobile_mapping::MapsSnapshot> resumed_maps_;
  uint64_t maps_saved_stops_ = 0;  // stops merged into the maps when they were last saved
  // RunMaps took a key frame into this frame's snapshot: `maps_key_frames` is counted only once
  // that snapshot is published, so a client that sees the count can already read those maps.
  bool key_frame_awaits_publish_ = false;
  std::chrono::steady_clock::time_point maps_saved_at_;
  // A reset asked for and not yet done; taken with each save so that no save of the old maps
  // lands after the store was cleared.
  std::mutex maps_reset_mutex_;
  bool maps_reset_requested_ = false;

  const ActiveModels* active_models_ = nullptr;
  RawFrameTap* frame_tap_ = nullptr;
  std::optional<ModelRectification> model_rectification_;

  // Shared with the maps' snapshots, whose readers add maps.perceptual_read (any thread, maybe
  // after the pipeline is gone).
  std::shared_ptr<RollingStats> stage_ms_ = std::make_shared<RollingStats>();
  RollingStats figures_;
  CounterSet events_;
  std::atomic<uint64_t> processed_{0};
  std::atomic<uint64_t> full_refreshes_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace epmap::mapping
