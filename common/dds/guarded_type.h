#pragma once
// A wrapper around a fastddsgen type support that refuses oversized payloads before decoding
// them and catches malformed ones. Fast DDS ignores a failed deserialize() and hands the
// half-filled sample to the reader as valid, so the verdict is left in a thread-local that
// the reader checks right after take_next_sample() (both run on the same listener thread).

#include <cstdint>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <string>

namespace epmap::dds {

enum class PayloadVerdict { kOk, kOversized, kMalformed };

// The verdict of the last deserialize() on this thread; reset to kOk by TakeVerdict().
PayloadVerdict TakeVerdict();
void SetVerdict(PayloadVerdict verdict);

template <class Base>
class GuardedType : public Base {
 public:
  explicit GuardedType(uint32_t max_payload_bytes) : max_payload_bytes_(max_payload_bytes) {}

  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    if (payload->length > max_payload_bytes_) {
      SetVerdict(PayloadVerdict::kOversized);
      return false;
    }
    try {
      if (Base::deserialize(payload, data)) return true;
    } catch (...) {
      // fastcdr throws on some malformed input (bad bool, string without terminator, ...).
    }
    SetVerdict(PayloadVerdict::kMalformed);
    return false;
  }

 private:
  uint32_t max_payload_bytes_;
};

}  // namespace epmap::dds
