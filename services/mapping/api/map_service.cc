#include "services/mapping/api/map_service.h"

#include "common/process/process_memory.h"
#include "services/mapping/api/proto_conversions.h"
#include "services/mapping/service.h"

namespace epmap::mapping {

namespace {

constexpr uint32_t kMaxWaitMs = 30000;

void AddCounters(const std::vector<std::pair<std::string, uint64_t>>& counts,
                 google::protobuf::RepeatedPtrField<v1::Counter>* out) {
  for (const auto& [reason, n] : counts) {
    auto* c = out->Add();
    c->set_reason(reason);
    c->set_count(n);
  }
}

}  // namespace

grpc::Status MapServiceImpl::GetStatus(grpc::ServerContext*, const v1::GetStatusRequest*,
                                       v1::ServiceStatus* out) {
  auto& pipeline = service_.pipeline();
  auto& counters = service_.counters();
  out->set_version(EPMAP_VERSION);
  out->set_uptime_s(service_.uptime_s());
  out->set_mode(pipeline.mode());
  for (const auto& t : service_.ingest().CollectTopicCounters()) {
    auto* c = out->add_messages_by_topic();
    c->set_reason(t.topic);
    c->set_count(t.received);
    if (t.lost) {
      auto* lost = out->add_transport_lost_by_topic();
      lost->set_reason(t.topic);
      lost->set_count(t.lost);
    }
  }
  out->set_frames_received(counters.frames_assembled.load());
  out->set_frames_processed(pipeline.frames_processed());
  out->set_frames_rejected(counters.rejected.Total());
  AddCounters(counters.rejected.Snapshot(), out->mutable_rejected_by_reason());
  out->set_key_frames_refused(counters.key_frames_refused.Total());
  AddCounters(counters.key_frames_refused.Snapshot(), out->mutable_key_frames_refused_by_reason());
  out->set_queue_dropped(counters.queue_drops.Total());
  AddCounters(counters.queue_drops.Snapshot(), out->mutable_queue_drops_by_reason());
  out->set_queue_depth(static_cast<uint32_t>(service_.queue().size()));
  out->set_queue_capacity(static_cast<uint32_t>(service_.queue().capacity()));
  for (const auto& [stage, s] : pipeline.stage_ms().Summaries()) {
    auto* t = out->add_stages();
    t->set_stage(stage);
    t->set_last_ms(s.last);
    t->set_median_ms(s.median);
    t->set_p99_ms(s.p99);
    t->set_mean_ms(s.mean);
    t->set_samples(s.samples);
  }
  if (const auto latest = service_.snapshots().Latest()) out->set_last_stamp_ns(latest->stamp_ns);
  const auto latency = pipeline.figures().Summary("latency_ms");
  out->set_latency_ms_p50(latency.median);
  out->set_latency_ms_p99(latency.p99);
  const auto share = pipeline.figures().Summary("recomputed_share");
  out->set_recomputed_share_last(share.last);
  out->set_recomputed_share_median(share.median);
  out->set_recomputed_share_mean(share.mean);
  out->set_full_refreshes(pipeline.full_refreshes());
  AddCounters(pipeline.events().Snapshot(), out->mutable_events());
  const auto& models = service_.calibration().active_models();
  out->set_active_eye_hand_model(models.eye_hand_id());
  out->set_active_stereo_model(models.stereo_id());
  out->set_unexpected_watchers(static_cast<uint32_t>(pipeline.unexpected_hub().subscribers()));
  const auto memory = process::ReadProcessMemory();
  out->set_resident_mb(memory.resident_mb);
  out->set_peak_resident_mb(memory.peak_resident_mb);
  if (const auto* chain = pipeline.chain()) {
    auto* robot = out->mutable_robot();
    robot->set_urdf(service_.config().urdf);
    robot->set_root_link(chain->root_link());
    robot->set_left_camera_link(chain->camera_links().left);
    if (chain->has_cam1()) robot->set_right_camera_link(chain->camera_links().right);
    for (const auto& joint : chain->joint_names()) robot->add_joints(joint);
    robot->set_pose_source(pipeline.EffectivePoseSource());
  }
  if (const MapsStore* store = pipeline.maps_store()) {
    auto* saved = out->mutable_saved_maps();
    saved->set_path(store->path().string());
    if (const auto on_disk = store->OnDisk()) {
      saved->set_saved(true);
      saved->set_saved_unix_ns(on_disk->saved_unix_ns);
      saved->set_key_frames(on_disk->key_frames);
      saved->set_bytes(on_disk->bytes);
    }
  }
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::CheckWait(int64_t newer_than_ns, uint32_t wait_ms) {
  if (wait_ms > kMaxWaitMs) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "wait_ms must be at most " +
                                                    std::to_string(kMaxWaitMs) + ", got " +
                                                    std::to_string(wait_ms)};
  }
  if (newer_than_ns < 0) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "newer_than_ns must not be negative"};
  }
  return grpc::Status::OK;
}

std::shared_ptr<const MapSnapshot> MapServiceImpl::WaitForSnapshot(
    grpc::ServerContext* context, uint32_t wait_ms,
    const std::function<bool(const MapSnapshot&)>& ready) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
  auto snapshot = service_.snapshots().Latest();
  while ((!snapshot || !ready(*snapshot)) && std::chrono::steady_clock::now() < deadline &&
         !context->IsCancelled() && !service_.shutting_down()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    snapshot = service_.snapshots().WaitNewer(snapshot ? snapshot->frame_index : 0,
                                              std::min(left, std::chrono::milliseconds(200)));
  }
  return snapshot;
}

grpc::Status MapServiceImpl::GetDisparity(grpc::ServerContext* context,
                                          const v1::GetDisparityRequest* request,
                                          v1::DisparityMap* out) {
  if (auto bad = CheckWait(request->newer_than_ns(), request->wait_ms()); !bad.ok()) return bad;
  const auto snapshot = WaitForSnapshot(context, request->wait_ms(), [&](const MapSnapshot& s) {
    return s.stamp_ns > request->newer_than_ns();
  });
  if (!snapshot) {
    return {grpc::StatusCode::UNAVAILABLE,
            "no frame has been processed yet (is a stereo source publishing on domain " +
                std::to_string(service_.config().domain) + "?)"};
  }
  if (snapshot->stamp_ns <= request->newer_than_ns()) {
    return {grpc::StatusCode::DEADLINE_EXCEEDED,
            "no frame newer than the requested stamp arrived within wait_ms"};
  }
  out->set_stamp_ns(snapshot->stamp_ns);
  out->set_frame_index(snapshot->frame_index);
  ToProto(snapshot->camera, snapshot->camera_frame(), out->mutable_camera());
  ToProto(snapshot->disparity, out->mutable_disparity());
  out->set_min_disparity(snapshot->min_disparity);
  out->set_num_disparities(snapshot->num_disparities);
  out->set_valid_share(snapshot->valid_share);
  out->set_recomputed_share(snapshot->recomputed_share);
  if (snapshot->T_base_cam0) {
    ToProto(*snapshot->T_base_cam0, snapshot->base_frame, snapshot->camera_link,
            out->mutable_camera_pose());
  }
  if (snapshot->T_odom_base) {
    ToProto(*snapshot->T_odom_base, service_.config().maps.odom_frame, snapshot->base_frame,
            out->mutable_base_pose());
  }
  return grpc::Status::OK;
}

}  // namespace epmap::mapping
