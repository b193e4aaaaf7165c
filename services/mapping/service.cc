#include "services/mapping/service.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>
#include <spdlog/spdlog.h>

#include <stdexcept>

#include "services/mapping/api/map_service.h"

namespace epmap::mapping {

MappingService::MappingService(const ServiceConfig& config)
    : config_(config),
      started_(std::chrono::steady_clock::now()),
      queue_(config.queue_capacity),
      sensors_(counters_.rejected) {
  config_.Validate();
  calibration_ = std::make_unique<CalibrationComponent>(config_, sensors_, counters_);
  pipeline_ = std::make_unique<Pipeline>(config_, queue_, sensors_, counters_, snapshots_);
  pipeline_->AttachCalibration(&calibration_->active_models(), &calibration_->frame_tap(),
                               config_.calibration.rectification_rebuild_deg);

  // Everything an RPC may touch exists before the server starts: a GetStatus arriving while
  // DDS ingest was still being created used to find it null (a crash at start-up).
  pipeline_->Start();
  ingest_ = std::make_unique<DdsIngest>(config_, queue_, sensors_, counters_);
  ingest_->SetEyeHandCallback(calibration_->EyeHandSamplesCallback());
  ros_maps_ = std::make_unique<RosMapPublisher>(config_, ingest_->participant(), snapshots_,
                                                pipeline_->events(),
                                                pipeline_->ResumedMapsBeforeFirstFrame());
  ros_perception_ = std::make_unique<RosPerceptionPublisher>(config_, ingest_->participant(),
                                                             snapshots_, pipeline_->events());

  map_service_ = std::make_unique<MapServiceImpl>(*this);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(config_.listen, grpc::InsecureServerCredentials(), &port);
  builder.SetMaxReceiveMessageSize(config_.max_message_mb << 20);
  builder.SetMaxSendMessageSize(config_.max_message_mb << 20);
  builder.RegisterService(map_service_.get());
  builder.RegisterService(calibration_->grpc_service());
  server_ = builder.BuildAndStart();
  if (!server_ || port == 0) {
    throw std::runtime_error("cannot serve gRPC on " + config_.listen +
                             " (address in use or invalid?)");
  }
  bound_address_ = config_.listen.substr(0, config_.listen.rfind(':') + 1) + std::to_string(port);
  server_->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info("epmapd serving gRPC on {} ; DDS domain {} ; mode {}", bound_address_,
               config_.domain, config_.mode);
}

MappingService::~MappingService() {
  Shutdown();
}

void MappingService::Shutdown() {
  if (shutting_down_.exchange(true)) return;
  spdlog::info("epmapd shutting down");
  if (server_) {
    server_->GetHealthCheckService()->SetServingStatus(false);
    snapshots_.Close();  // wakes RPCs waiting for a newer frame
    // Running calibration jobs end INTERRUPTED; their watchers see that and return.
    if (calibration_) calibration_->Shutdown();
    server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  }
  ros_maps_.reset();  // before the participant they write through
  ros_perception_.reset();
  ingest_.reset();  // no more DDS callbacks
  queue_.Close();
  if (pipeline_) pipeline_->Stop();
  if (calibration_) calibration_->Shutdown();
  if (server_) server_->Wait();
  spdlog::info("epmapd stopped");
}

double MappingService::uptime_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
}

}  // namespace epmap::mapping
