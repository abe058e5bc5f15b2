// The ray-crossing rule's settings (the walk itself is a template in the header, inlined where used).
#include "pl/registration/ray_crossing.hpp"

#include <string>

#include "pl/common/error.hpp"

namespace pl::registration {

void RayCrossingConfig::validate() const {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw Error(std::string("ray crossing: ") + what);
  };
  need(start_m >= 0 && start_m <= 500, "start_m must be within 0..500 m");
  need(step_m > 0.01 && step_m <= 40, "step_m must be within (0.01, 40] m");
  need(margin_m >= 0 && margin_m <= 100, "margin_m must be within 0..100 m");
  need(pass_radius_m > 0 && pass_radius_m <= 2, "pass_radius_m must be within (0, 2] m");
  need(cross_radius_m > 0 && cross_radius_m <= 2, "cross_radius_m must be within (0, 2] m");
  need(min_incidence >= 0 && min_incidence <= 1, "min_incidence must be within 0..1");
}

}  // namespace pl::registration
