// The parametric force model (identification/parametric_dynamics.hpp) against the simulator's
// (dynamics/vehicle_dynamics.hpp): equal at theta = initial for every switch combination, every
// shipped model and random states, and its parameter derivatives (ceres::Jet) equal central
// differences of the simulator's model with the parameter changed in the model file's spec.
#include "dronetwin/identification/parametric_dynamics.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <string>

#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

DisturbanceSwitches switches_from_bits(int bits) {
  return {(bits & 1) != 0, (bits & 2) != 0,  (bits & 4) != 0,
          (bits & 8) != 0, (bits & 16) != 0, (bits & 32) != 0};
}

RotorVector random_speeds(const VehicleModel& m, Random& rng) {
  RotorVector w(m.num_rotors());
  for (int i = 0; i < m.num_rotors(); ++i) w[i] = 300.0 + 2500.0 * rng.uniform();
  return w;
}

TEST(ParametricDynamics, EqualsTheSimulatorModelForEverySwitchCombination) {
  for (const std::string name : {"qdrone2", "hexarotor", "tilted_hexarotor", "crazyflie21"}) {
    const auto model = test::load_model(name);
    Random rng(11);
    Environment env;
    env.wind_W_m_s = Vec3(1.5, -0.7, 0.3);
    for (int bits = 0; bits < 64; ++bits) {
      const DisturbanceSwitches sw = switches_from_bits(bits);
      const ParametricModel pm(*model, sw, env);
      for (int trial = 0; trial < 5; ++trial) {
        // z from 0.01 m: the ground-effect floor is crossed on some trials
        const StateVector x = test::random_state(rng, 0.01, 0.5);
        const RotorVector w = random_speeds(*model, rng);
        const StateVector expected = state_derivative<double>(*model, sw, env, x, w);
        const StateVector got = pm.derivative<double, double>(pm.initial_theta().data(), x, w);
        EXPECT_LT((got - expected).norm(), 1e-12 * (1.0 + expected.norm()))
            << name << " switches " << bits << " trial " << trial << "\n"
            << got.transpose() << "\n"
            << expected.transpose();
      }
    }
  }
}

TEST(ParametricDynamics, ParameterDerivativesMatchCentralDifferencesOfTheSimulatorModel) {
  const auto model = test::load_model("qdrone2");
  const DisturbanceSwitches sw{};
  const Environment env;
  const ParametricModel pm(*model, sw, env);
  Random rng(5);
  const StateVector x = test::random_state(rng, 0.03, 0.2);  // near the ground: C_G matters
  const RotorVector w = random_speeds(*model, rng);
  using Jet = ceres::Jet<double, kNumModelParameters>;
  std::array<Jet, kNumModelParameters> theta;
  for (int j = 0; j < kNumModelParameters; ++j) {
    theta[static_cast<std::size_t>(j)] = Jet(pm.initial_theta()[static_cast<std::size_t>(j)], j);
  }
  const StateVectorT<Jet> d = pm.derivative<Jet, double>(theta.data(), x, w);
  for (int j = 0; j < kNumModelParameters; ++j) {
    const auto p = static_cast<ModelParameter>(j);
    if (is_motor_parameter(p)) continue;  // they do not enter the rigid-body derivative
    // d/dtheta of the simulator's model: change the parameter in the spec by +-h of its value.
    const double v0 = parameter_value(model->spec(), p), h = 1e-5;
    const auto derivative_at = [&](double factor) {
      VehicleSpec spec = model->spec();
      set_parameter_value(spec, p, v0 * factor);
      const VehicleModel changed(spec);
      return StateVector(state_derivative<double>(changed, sw, env, x, w));
    };
    // per unit of theta = value / v0
    const StateVector numeric = (derivative_at(1.0 + h) - derivative_at(1.0 - h)) / (2.0 * h);
    for (int i = 0; i < kStateSize; ++i) {
      EXPECT_NEAR(d[i].v[j], numeric[i], 1e-6 * (1.0 + std::abs(numeric[i])))
          << parameter_name(p) << " state " << i;
    }
  }
}

}  // namespace
}  // namespace dronetwin
