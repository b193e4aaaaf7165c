#include "common/dds/guarded_type.h"

namespace epmap::dds {

namespace {
thread_local PayloadVerdict t_verdict = PayloadVerdict::kOk;
}

PayloadVerdict TakeVerdict() {
  const PayloadVerdict v = t_verdict;
  t_verdict = PayloadVerdict::kOk;
  return v;
}

void SetVerdict(PayloadVerdict verdict) {
  t_verdict = verdict;
}

}  // namespace epmap::dds
