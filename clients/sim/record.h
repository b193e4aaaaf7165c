#pragma once
// Writes a scenario to disk in the dataset layout of ../shared/docs/dataset-layout.md, with
// epmap-sim's ground-truth extensions (clients/sim/README.md lists them).

#include <filesystem>
#include <functional>

#include "clients/sim/scenario.h"

namespace epmap::sim {

// Called after each frame is written with (frames done, frames in all).
using RecordProgress = std::function<void(int done, int total)>;

// Records every frame of `scenario` under out/mav0. Throws std::runtime_error if `out` exists
// and is not empty (unless `force`, which replaces its content) or a file cannot be written.
void Record(const Scenario& scenario, const std::filesystem::path& out, bool force,
            const RecordProgress& progress = {});

}  // namespace epmap::sim
