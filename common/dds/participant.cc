#include "common/dds/participant.h"

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <memory>
#include <stdexcept>

namespace epmap::dds {

using namespace eprosima::fastdds::dds;
using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;

Participant::Participant(uint32_t domain_id, const std::string& name,
                         const TransportOptions& transport)
    : domain_id_(domain_id) {
  if (domain_id > 232) {
    throw std::invalid_argument("DDS domain id must be in 0..232, got " +
                                std::to_string(domain_id));
  }
  DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  qos.transport().use_builtin_transports = false;
  if (transport.shared_memory) {
    auto shm = std::make_shared<SharedMemTransportDescriptor>();
    shm->segment_size(transport.shm_segment_bytes);
    qos.transport().user_transports.push_back(shm);
  }
  if (transport.udp || !transport.shared_memory) {
    auto udp = std::make_shared<UDPv4TransportDescriptor>();
    udp->sendBufferSize = transport.udp_buffer_bytes;
    udp->receiveBufferSize = transport.udp_buffer_bytes;
    qos.transport().user_transports.push_back(udp);
    qos.transport().send_socket_buffer_size = transport.udp_buffer_bytes;
    qos.transport().listen_socket_buffer_size = transport.udp_buffer_bytes;
  }
  participant_ = DomainParticipantFactory::get_instance()->create_participant(domain_id, qos);
  if (!participant_) {
    throw std::runtime_error("cannot create a DDS participant on domain " +
                             std::to_string(domain_id));
  }
}

Participant::~Participant() {
  if (participant_) {
    participant_->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
}

Publisher* Participant::publisher() {
  std::lock_guard lock(mutex_);
  if (!publisher_) publisher_ = participant_->create_publisher(PUBLISHER_QOS_DEFAULT);
  if (!publisher_) throw std::runtime_error("cannot create a DDS publisher");
  return publisher_;
}

Subscriber* Participant::subscriber() {
  std::lock_guard lock(mutex_);
  if (!subscriber_) subscriber_ = participant_->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
  if (!subscriber_) throw std::runtime_error("cannot create a DDS subscriber");
  return subscriber_;
}

eprosima::fastdds::dds::Topic* Participant::Topic(const std::string& topic_name, TypeSupport type) {
  std::lock_guard lock(mutex_);
  if (auto it = topics_.find(topic_name); it != topics_.end()) return it->second;
  if (!participant_->find_type(type.get_type_name())) {
    if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
      throw std::runtime_error("cannot register DDS type " + type.get_type_name());
    }
  }
  auto* topic = participant_->create_topic(topic_name, type.get_type_name(), TOPIC_QOS_DEFAULT);
  if (!topic) {
    throw std::runtime_error("cannot create DDS topic " + topic_name + " of type " +
                             type.get_type_name());
  }
  topics_[topic_name] = topic;
  return topic;
}

std::string RosTopic(const std::string& name) {
  if (name.rfind("rt/", 0) == 0) return name;
  if (!name.empty() && name[0] == '/') return "rt" + name;
  return "rt/" + name;
}

}  // namespace epmap::dds
