#pragma once
// Shared helpers for the test suite: model loading by name, seeded random states.

#include <memory>
#include <string>

#include "dronetwin/io/model_loader.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin::test {

inline std::string source_path(const std::string& relative) {
  return std::string(DRONETWIN_SOURCE_DIR) + "/" + relative;
}

inline std::shared_ptr<const VehicleModel> load_model(const std::string& name) {
  return std::make_shared<const VehicleModel>(
      load_vehicle_model(source_path("models/" + name + ".yaml")));
}

/// A state with every component away from zero: position, velocity, attitude and body rate.
inline StateVector random_state(Random& rng, double z_min = 0.05, double z_max = 3.0) {
  StateVector x;
  x.segment<2>(0) << 4 * rng.uniform() - 2, 4 * rng.uniform() - 2;
  x[2] = z_min + (z_max - z_min) * rng.uniform();
  for (int i = 3; i < 6; ++i) x[i] = 6 * rng.uniform() - 3;
  x.segment<4>(6) = math::from_euler(rng.uniform() - 0.5, rng.uniform() - 0.5, 6 * rng.uniform());
  for (int i = 10; i < 13; ++i) x[i] = 4 * rng.uniform() - 2;
  return x;
}

}  // namespace dronetwin::test
