#include <stdexcept>
#include "clients/sim/scenario_factories.h"
namespace epmap::sim {
std::unique_ptr<Scenario> MakeBuildingScenario(const ScenarioOptions&) {
  throw std::invalid_argument("scenario building is not available yet in this build");
}
}  // namespace epmap::sim
