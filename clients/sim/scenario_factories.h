#pragma once
// The concrete scenarios behind MakeScenario (internal to clients/sim). Options arrive
// validated: sizes positive or zero (= default), scales non-negative.

#include <memory>

#include "clients/sim/scenario.h"

namespace epmap::sim {

std::unique_ptr<Scenario> MakeHeadScenario(const ScenarioOptions& options, bool vergence);
std::unique_ptr<Scenario> MakeBuildingScenario(const ScenarioOptions& options);
std::unique_ptr<Scenario> MakeEyeHandScenario(const ScenarioOptions& options);

}  // namespace epmap::sim
