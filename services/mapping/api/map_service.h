#pragma once
// epmap.v1.MapService: reads the pipeline's newest snapshot and the service's counters.
// Never blocks the pipeline; invalid arguments get INVALID_ARGUMENT with a message.

#include <epmap/v1/map_service.grpc.pb.h>

#include <functional>
#include <memory>

namespace epmap::mobile_mapping {
struct MapsSnapshot;
}

namespace epmap::mapping {

class MappingService;
struct MapSnapshot;

class MapServiceImpl final : public v1::MapService::Service {
 public:
  explicit MapServiceImpl(MappingService& service) : service_(service) {}

  grpc::Status GetStatus(grpc::ServerContext* context, const v1::GetStatusRequest* request,
                         v1::ServiceStatus* response) override;
  grpc::Status GetDisparity(grpc::ServerContext* context, const v1::GetDisparityRequest* request,
                            v1::DisparityMap* response) override;
  // Expected perception (paper 000), in map_service_ep.cc.
  grpc::Status GetExpectation(grpc::ServerContext* context,
                              const v1::GetExpectationRequest* request,
                              v1::Expectation* response) override;
  grpc::Status GetUnexpectedRegions(grpc::ServerContext* context,
                                    const v1::GetUnexpectedRegionsRequest* request,
                                    v1::UnexpectedRegions* response) override;
  grpc::Status WatchUnexpected(grpc::ServerContext* context,
                               const v1::WatchUnexpectedRequest* request,
                               grpc::ServerWriter<v1::UnexpectedEvent>* writer) override;
  // Mobile-base mode: the maps of the newest key frame (map_service_maps.cc).
  grpc::Status GetPerceptualMap(grpc::ServerContext* context,
                                const v1::GetPerceptualMapRequest* request,
                                v1::PerceptualMap* response) override;
  grpc::Status GetOccupancyGrid(grpc::ServerContext* context,
                                const v1::GetOccupancyGridRequest* request,
                                v1::OccupancyGrid* response) override;
  grpc::Status ResetMaps(grpc::ServerContext* context, const v1::ResetMapsRequest* request,
                         v1::ResetMapsResponse* response) override;
  grpc::Status GetPose(grpc::ServerContext* context, const v1::GetPoseRequest* request,
                       v1::PoseEstimate* response) override;

 private:
  // newer_than_ns / wait_ms as the requests that take them: INVALID_ARGUMENT for a negative stamp
  // or a wait beyond 30 s.
  static grpc::Status CheckWait(int64_t newer_than_ns, uint32_t wait_ms);
  // The newest snapshot, after waiting up to wait_ms (the call's cancellation and shutdown end
  // the wait early) for one that `ready` accepts; may be null or not ready when the wait ends.
  std::shared_ptr<const MapSnapshot> WaitForSnapshot(
      grpc::ServerContext* context, uint32_t wait_ms,
      const std::function<bool(const MapSnapshot&)>& ready);
  // The maps of the newest snapshot (waiting as above for maps stamped after newer_than_ns), or
  // why there are none: FAILED_PRECONDITION (not a mobile base, maps off, no key frame yet),
  // DEADLINE_EXCEEDED (maps, but none newer within wait_ms).
  grpc::Status LatestMaps(grpc::ServerContext* context, int64_t newer_than_ns, uint32_t wait_ms,
                          std::shared_ptr<const mobile_mapping::MapsSnapshot>* maps);

  MappingService& service_;
};

}  // namespace epmap::mapping
