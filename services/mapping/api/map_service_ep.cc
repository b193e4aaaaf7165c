// MapService's expected-perception RPCs (paper 000): the newest frame's prediction and
// comparison images, the regions that moved on their own, and a stream of them as they happen.

#include <opencv2/imgproc.hpp>

#include "services/mapping/api/map_service.h"
#include "services/mapping/api/proto_conversions.h"
#include "services/mapping/service.h"

namespace epmap::mapping {

namespace {

// No image this service handles is larger; a bigger minimum area can only be a mistake.
constexpr uint32_t kMaxMinAreaPx = 4096u * 4096u;
// How often a watch stream wakes to notice a cancelled client or a shutdown.
constexpr std::chrono::milliseconds kWatchPoll{200};

grpc::Status CheckEpEnabled(const MappingService& service) {
  if (!service.config().ep.enabled) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "expected perception is disabled in this service's config (ep.enabled: false)"};
  }
  return grpc::Status::OK;
}

grpc::Status CheckMinArea(uint32_t min_area_px) {
  if (min_area_px > kMaxMinAreaPx) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "min_area_px must be at most " +
                                                    std::to_string(kMaxMinAreaPx) + ", got " +
                                                    std::to_string(min_area_px)};
  }
  return grpc::Status::OK;
}

void RegionToProto(const UnexpectedRegionInfo& r, int64_t stamp_ns, uint64_t frame_index,
                   v1::UnexpectedRegion* out) {
  out->set_stamp_ns(stamp_ns);
  out->set_frame_index(frame_index);
  out->set_id(r.id);
  out->set_x(r.box.x);
  out->set_y(r.box.y);
  out->set_width(r.box.width);
  out->set_height(r.box.height);
  out->set_area_px(static_cast<uint32_t>(r.area_px));
  out->set_mean_disparity(r.mean_disparity_px);
  if (r.has_centroid) {
    ToProto(r.centroid_camera, out->mutable_centroid_camera());
    ToProto(r.centroid_base, out->mutable_centroid_base());
    if (r.centroid_odom) ToProto(*r.centroid_odom, out->mutable_centroid_odom());
  } else {
    // No pixel of the region had a disparity: its position is unknown, said as NaN.
    const Eigen::Vector3d unknown = Eigen::Vector3d::Constant(std::nan(""));
    ToProto(unknown, out->mutable_centroid_camera());
    ToProto(unknown, out->mutable_centroid_base());
    if (r.centroid_odom) ToProto(unknown, out->mutable_centroid_odom());
  }
  out->set_base_corrected(r.base_corrected);
}

// Fills the shared fields of UnexpectedRegions / UnexpectedEvent.
template <typename Message>
void FillRegions(const UnexpectedFrame& frame, uint32_t min_area_px, Message* out) {
  out->set_stamp_ns(frame.stamp_ns);
  out->set_frame_index(frame.frame_index);
  out->set_flagged_share(frame.flagged_share);
  for (const auto& r : frame.regions) {
    if (static_cast<uint32_t>(r.area_px) < min_area_px) continue;
    RegionToProto(r, frame.stamp_ns, frame.frame_index, out->add_regions());
  }
}

// A grey-level image on the comparison grid as 8-bit (predicted L-: 0 at holes).
cv::Mat GreyLevels(const cv::Mat& image_f32) {
  cv::Mat out;
  image_f32.convertTo(out, CV_8U);  // saturates: grey levels are 0..255 already
  return out;
}

// The rectified left image sampled on the comparison grid as the comparator saw it (every
// step-th pixel, in grey).
cv::Mat ActualOnGrid(const cv::Mat& left, int step) {
  cv::Mat grey = left;
  if (left.channels() == 3) cv::cvtColor(left, grey, cv::COLOR_BGR2GRAY);
  if (step <= 1) return grey;
  cv::Mat out;
  cv::resize(grey, out, cv::Size((grey.cols + step - 1) / step, (grey.rows + step - 1) / step), 0,
             0, cv::INTER_NEAREST);
  return out;
}

}  // namespace

grpc::Status MapServiceImpl::GetExpectation(grpc::ServerContext*, const v1::GetExpectationRequest*,
                                            v1::Expectation* out) {
  if (auto status = CheckEpEnabled(service_); !status.ok()) return status;
  const auto snapshot = service_.snapshots().Latest();
  if (!snapshot || !snapshot->ep) {
    return {grpc::StatusCode::UNAVAILABLE, "no frame has been processed yet"};
  }
  const ep::EpResult& ep = *snapshot->ep;
  out->set_stamp_ns(snapshot->stamp_ns);
  out->set_frame_index(snapshot->frame_index);
  ToProto(snapshot->camera, snapshot->camera_frame(), out->mutable_camera());
  // A frame computed whole (first, scheduled refresh, pose jump) had nothing predicted: its
  // grid images stay empty, frame_mode says why, and the masks are still meaningful.
  if (ep.compared) {
    ToProto(GreyLevels(ep.predicted_left), out->mutable_predicted());
    ToProto(ActualOnGrid(snapshot->left_rectified, snapshot->grid_step), out->mutable_actual());
    ToProto(ep.error, out->mutable_error());
    ToProto(ep.accumulated, out->mutable_accumulated());
    ToProto(ep.attenuated, out->mutable_attenuated());
  }
  ToProto(ep.unexpected, out->mutable_unexpected_mask());
  ToProto(ep.recompute, out->mutable_recompute_mask());
  out->set_mean_error(ep.mean_error);
  out->set_mean_attenuated(ep.mean_attenuated);
  out->set_hole_share(ep.hole_share);
  out->set_recomputed_share(ep.recomputed_share);
  out->set_grid_step(static_cast<uint32_t>(snapshot->grid_step));
  out->set_frame_mode(ep::ToString(ep.mode));
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::GetUnexpectedRegions(grpc::ServerContext*,
                                                  const v1::GetUnexpectedRegionsRequest* request,
                                                  v1::UnexpectedRegions* out) {
  if (auto status = CheckEpEnabled(service_); !status.ok()) return status;
  if (auto status = CheckMinArea(request->min_area_px()); !status.ok()) return status;
  const auto snapshot = service_.snapshots().Latest();
  if (!snapshot || !snapshot->unexpected) {
    return {grpc::StatusCode::UNAVAILABLE, "no frame has been processed yet"};
  }
  FillRegions(*snapshot->unexpected, request->min_area_px(), out);
  return grpc::Status::OK;
}

grpc::Status MapServiceImpl::WatchUnexpected(grpc::ServerContext* context,
                                             const v1::WatchUnexpectedRequest* request,
                                             grpc::ServerWriter<v1::UnexpectedEvent>* writer) {
  if (auto status = CheckEpEnabled(service_); !status.ok()) return status;
  if (auto status = CheckMinArea(request->min_area_px()); !status.ok()) return status;
  auto& hub = service_.pipeline().unexpected_hub();
  const auto subscription = hub.Subscribe();
  while (!context->IsCancelled() && !service_.shutting_down()) {
    const auto frame = subscription->Next(kWatchPoll);
    if (!frame) continue;
    v1::UnexpectedEvent event;
    FillRegions(*frame, request->min_area_px(), &event);
    if (event.regions_size() == 0 && !request->include_empty()) continue;
    if (!writer->Write(event)) break;  // the client went away
  }
  hub.Unsubscribe(subscription);
  if (service_.shutting_down()) return {grpc::StatusCode::UNAVAILABLE, "the service is stopping"};
  return grpc::Status::OK;
}

}  // namespace epmap::mapping
