#pragma once
// Typed DDS writers and readers with the QoS the project uses everywhere:
//   readers BEST_EFFORT + VOLATILE (they match any writer, as ROS's sensor-data profile),
//   writers RELIABLE + VOLATILE (every reader matches them).
// A latched topic (ROS's "transient local": rt/map, as map_server publishes it) keeps its last
// samples for readers that join later: Durability::kTransientLocal on the writer, and on a
// reader that wants them (reliable then, which a best-effort reader cannot ask of history).
// Readers copy each sample out on Fast DDS's listener thread and hand it to a callback that
// must not block.

#include <atomic>
#include <chrono>
#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>

#include "common/dds/guarded_type.h"
#include "common/dds/participant.h"

namespace epmap::dds {

// What a reader saw of the transport itself, before any content validation.
struct ReaderCounters {
  std::atomic<uint64_t> received{0};   // samples taken with valid data
  std::atomic<uint64_t> oversized{0};  // refused before decoding (over max_payload_bytes)
  std::atomic<uint64_t> malformed{0};  // failed to decode
  std::atomic<uint64_t> lost{0};       // reported lost by DDS (best-effort gaps)
  std::atomic<uint64_t> rejected{0};   // rejected by DDS (resource limits)
};

enum class Durability { kVolatile, kTransientLocal };

template <class Msg, class PubSubType>
class Writer {
 public:
  Writer(Participant& participant, const std::string& topic_name, int depth = 10,
         Durability durability = Durability::kVolatile) {
    using namespace eprosima::fastdds::dds;
    auto* topic = participant.Topic(topic_name, TypeSupport(new PubSubType()));
    DataWriterQos qos = DATAWRITER_QOS_DEFAULT;
    qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = durability == Durability::kTransientLocal
                                ? TRANSIENT_LOCAL_DURABILITY_QOS
                                : VOLATILE_DURABILITY_QOS;
    qos.history().kind = KEEP_LAST_HISTORY_QOS;
    qos.history().depth = depth;
    // Images are large and unbounded: let the history grow payloads as needed.
    qos.endpoint().history_memory_policy =
        eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
    writer_ = participant.publisher()->create_datawriter(topic, qos);
    if (!writer_) throw std::runtime_error("cannot create a DDS writer on " + topic_name);
    topic_name_ = topic_name;
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  bool Write(Msg& msg) { return writer_->write(&msg); }

  int MatchedReaders() const {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count;
  }

  // Blocks until at least `count` readers matched or the timeout passed.
  bool WaitForReaders(int count, std::chrono::milliseconds timeout) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (MatchedReaders() < count) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return true;
  }

  // Waits until every matched reader acknowledged what was written (reliable readers only).
  void WaitForAcknowledgments(std::chrono::milliseconds timeout) {
    eprosima::fastrtps::Duration_t t(static_cast<int32_t>(timeout.count() / 1000),
                                     static_cast<uint32_t>((timeout.count() % 1000) * 1000000));
    writer_->wait_for_acknowledgments(t);
  }

  const std::string& topic_name() const { return topic_name_; }

 private:
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::string topic_name_;
};

template <class Msg, class PubSubType>
class Reader : public eprosima::fastdds::dds::DataReaderListener {
 public:
  using Callback = std::function<void(Msg&& msg)>;

  // max_payload_bytes: samples larger than this are refused before decoding.
  // kTransientLocal: also the samples a latched writer kept from before this reader (reliable).
  Reader(Participant& participant, const std::string& topic_name, Callback on_sample,
         uint32_t max_payload_bytes, int depth = 5, Durability durability = Durability::kVolatile)
      : on_sample_(std::move(on_sample)) {
    using namespace eprosima::fastdds::dds;
    // The guarded type registers under the same ROS type name as the plain one.
    auto* topic =
        participant.Topic(topic_name, TypeSupport(new GuardedType<PubSubType>(max_payload_bytes)));
    DataReaderQos qos = DATAREADER_QOS_DEFAULT;
    const bool latched = durability == Durability::kTransientLocal;
    qos.reliability().kind = latched ? RELIABLE_RELIABILITY_QOS : BEST_EFFORT_RELIABILITY_QOS;
    qos.durability().kind = latched ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
    qos.history().kind = KEEP_LAST_HISTORY_QOS;
    qos.history().depth = depth;
    qos.endpoint().history_memory_policy =
        eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
    reader_ = participant.subscriber()->create_datareader(topic, qos, this, StatusMask::all());
    if (!reader_) throw std::runtime_error("cannot create a DDS reader on " + topic_name);
  }
  ~Reader() override {
    if (reader_) reader_->set_listener(nullptr);
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const ReaderCounters& counters() const { return counters_; }

  int MatchedWriters() const {
    eprosima::fastdds::dds::SubscriptionMatchedStatus status;
    reader_->get_subscription_matched_status(status);
    return status.current_count;
  }

  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    eprosima::fastdds::dds::SampleInfo info;
    Msg msg;
    // Bounded: a sample that fails to decode must not keep us here.
    for (int attempt = 0; attempt < 1024; ++attempt) {
      TakeVerdict();  // clear
      const ReturnCode_t code = reader->take_next_sample(&msg, &info);
      // Fast DDS drops a sample whose deserialize() failed (take returns an error for it):
      // the verdict says why, and the next sample may still be fine.
      const PayloadVerdict verdict = TakeVerdict();
      if (verdict != PayloadVerdict::kOk) {
        (verdict == PayloadVerdict::kOversized ? counters_.oversized : counters_.malformed)++;
        msg = Msg();
        continue;
      }
      if (code != ReturnCode_t::RETCODE_OK) break;
      if (!info.valid_data) continue;
      counters_.received++;
      on_sample_(std::move(msg));
      msg = Msg();
    }
  }

  void on_sample_lost(eprosima::fastdds::dds::DataReader*,
                      const eprosima::fastdds::dds::SampleLostStatus& status) override {
    counters_.lost.store(static_cast<uint64_t>(status.total_count));
  }

  void on_sample_rejected(eprosima::fastdds::dds::DataReader*,
                          const eprosima::fastdds::dds::SampleRejectedStatus& status) override {
    counters_.rejected.store(static_cast<uint64_t>(status.total_count));
  }

 private:
  using ReturnCode_t = eprosima::fastrtps::types::ReturnCode_t;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  Callback on_sample_;
  ReaderCounters counters_;
};

}  // namespace epmap::dds
