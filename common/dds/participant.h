#pragma once
// A Fast DDS participant set up for images: the default transports drop 1 MB samples at
// 30 Hz (512 KiB shared-memory segment, ~200 KB UDP socket buffers), so every epmap process
// uses a 16 MiB shared-memory segment for same-host traffic plus UDPv4 with 4 MiB socket
// buffers for other hosts (see ../shared/docs/dds-grpc-notes.md).

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <map>
#include <mutex>
#include <string>

namespace epmap::dds {

struct TransportOptions {
  bool shared_memory = true;
  uint32_t shm_segment_bytes = 16u << 20;
  bool udp = true;
  uint32_t udp_buffer_bytes = 4u << 20;
};

// Owns a DomainParticipant with one publisher and one subscriber, and the topics created on
// it. Not copyable; destroying it deletes every entity it created.
class Participant {
 public:
  Participant(uint32_t domain_id, const std::string& name, const TransportOptions& transport = {});
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  eprosima::fastdds::dds::DomainParticipant* participant() { return participant_; }
  eprosima::fastdds::dds::Publisher* publisher();
  eprosima::fastdds::dds::Subscriber* subscriber();

  // Registers the type (once per type name) and returns the topic, creating it on first use.
  eprosima::fastdds::dds::Topic* Topic(const std::string& topic_name,
                                       eprosima::fastdds::dds::TypeSupport type);

  uint32_t domain_id() const { return domain_id_; }

 private:
  uint32_t domain_id_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
  std::mutex mutex_;
};

// ROS 2 puts topic "/a/b" on the wire as "rt/a/b". Accepts "/a/b", "a/b" or "rt/a/b".
std::string RosTopic(const std::string& name);

}  // namespace epmap::dds
