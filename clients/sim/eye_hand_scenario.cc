#include <stdexcept>
#include "clients/sim/scenario_factories.h"
namespace epmap::sim {
std::unique_ptr<Scenario> MakeEyeHandScenario(const ScenarioOptions&) {
  throw std::invalid_argument("scenario eye-hand is not available yet in this build");
}
}  // namespace epmap::sim
