#pragma once
// EpParams by name, for configuration files and command lines ("comparator.threshold_grey=25"):
// one list of keys, so that the service's config and the benchmark's --set agree.

#include <string>
#include <utility>
#include <vector>

#include "perception/ep/expected_perception.h"

namespace epmap::ep {

// Sets one parameter. Throws std::invalid_argument naming the key if it is unknown or the
// value does not parse (the value is checked by EpParams::Validate() only later).
void SetEpParam(EpParams* params, const std::string& key, const std::string& value);

// Every key with its current value, in a stable order.
std::vector<std::pair<std::string, std::string>> ListEpParams(const EpParams& params);

}  // namespace epmap::ep
