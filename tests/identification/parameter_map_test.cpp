// The fit's parameter map (identification/parameter_map.hpp): theta = initial reproduces the model
// exactly, and the force kernel's derivatives with respect to theta (ceres::Jet through
// model_at) equal central differences of the kernel with the parameter changed in the model
// file's spec.
#include "dronetwin/identification/parameter_map.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <string>

#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

RotorVector random_speeds(const VehicleModel& m, Random& rng) {
  RotorVector w(m.num_rotors());
  for (int i = 0; i < m.num_rotors(); ++i) w[i] = 300.0 + 2500.0 * rng.uniform();
  return w;
}

TEST(ParameterMap, InitialThetaIsTheModelItself) {
  for (const std::string name : {"qdrone2", "hexarotor", "tilted_hexarotor", "crazyflie21"}) {
    const auto model = test::load_model(name);
    const ParameterMap pm(*model);
    const VehicleModelTpl<double> at = pm.model_at(pm.initial_theta().data());
    EXPECT_EQ(at.mass_kg(), model->mass_kg()) << name;
    EXPECT_EQ(at.inertia_kgm2(), model->inertia_kgm2()) << name;
    EXPECT_EQ(at.body_drag_Ns_per_m(), model->body_drag_Ns_per_m()) << name;
    for (int i = 0; i < model->num_rotors(); ++i) {
      const RotorParams& a = at.rotor(i);
      const RotorParams& b = model->rotor(i);
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(a.thrust_coefficients[static_cast<std::size_t>(k)],
                  b.thrust_coefficients[static_cast<std::size_t>(k)]);
      EXPECT_EQ(a.yaw_moment_per_thrust_m, b.yaw_moment_per_thrust_m);
      EXPECT_EQ(a.drag_moment_coefficient, b.drag_moment_coefficient);
      EXPECT_EQ(a.rotor_drag_coefficient, b.rotor_drag_coefficient);
      EXPECT_EQ(a.rolling_moment_coefficient, b.rolling_moment_coefficient);
      EXPECT_EQ(a.ground_effect_coefficient, b.ground_effect_coefficient);
      EXPECT_EQ(a.time_constant_rise_s, b.time_constant_rise_s);
      EXPECT_EQ(a.time_constant_fall_s, b.time_constant_fall_s);
      EXPECT_EQ(a.position_m, b.position_m);
      EXPECT_EQ(a.axis, b.axis);
      EXPECT_EQ(a.spin, b.spin);
    }
    // and value() reads the spec's number back
    for (int j = 0; j < kNumModelParameters; ++j) {
      const auto p = static_cast<ModelParameter>(j);
      EXPECT_DOUBLE_EQ(pm.value(p, pm.initial_theta()[static_cast<std::size_t>(j)]),
                       parameter_value(model->spec(), p))
          << name << " " << parameter_name(p);
    }
  }
}

TEST(ParameterMap, ParameterDerivativesMatchCentralDifferencesOfTheKernel) {
  const auto model = test::load_model("qdrone2");
  const DisturbanceSwitches sw{};
  const Environment env;
  const ParameterMap pm(*model);
  Random rng(5);
  const StateVector x = test::random_state(rng, 0.03, 0.2);  // near the ground: C_G matters
  const RotorVector w = random_speeds(*model, rng);
  using Jet = ceres::Jet<double, kNumModelParameters>;
  std::array<Jet, kNumModelParameters> theta;
  for (int j = 0; j < kNumModelParameters; ++j) {
    theta[static_cast<std::size_t>(j)] = Jet(pm.initial_theta()[static_cast<std::size_t>(j)], j);
  }
  const StateVectorT<Jet> d = state_derivative(pm.model_at(theta.data()), sw, env, x, w);
  for (int j = 0; j < kNumModelParameters; ++j) {
    const auto p = static_cast<ModelParameter>(j);
    if (is_motor_parameter(p)) continue;  // they do not enter the rigid-body derivative
    // d/dtheta of the model: change the parameter in the spec by +-h of its value.
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
