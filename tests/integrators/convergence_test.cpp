// Order of accuracy of the fixed-step integrators on the full nonlinear vehicle model (all
// disturbance terms, unequal rotor speeds so the body tumbles and translates): halving dt must
// divide the global error at a fixed end time by ~2^4 = 16 for RK4 and ~2 for explicit Euler.
// The reference solution is RK4 with a step 64x smaller than the finest step tested.

#include <gtest/gtest.h>

#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

struct Problem {
  std::shared_ptr<const VehicleModel> model = test::load_model("qdrone2");
  Environment env;
  RotorVector w;
  StateVector x0;
  Problem() {
    w = RotorVector(4);
    w << 1200.0, 1150.0, 1180.0, 1210.0;
    env.wind_W_m_s << 1.0, -0.5, 0.0;
    x0 = Simulator_like_start();
  }
  static StateVector Simulator_like_start() {
    StateVector x = StateVector::Zero();
    x.segment<3>(0) << 0.0, 0.0, 0.4;  // low enough for the ground effect to matter
    x.segment<3>(3) << 1.0, 0.5, 0.2;
    x.segment<4>(6) = math::from_euler(0.2, -0.1, 0.3);
    x.segment<3>(10) << 0.5, -0.4, 0.3;
    return x;
  }
  StateVector solve(Integrator method, double dt, double t_end) const {
    StateVector x = x0;
    const auto f = [&](const StateVector& s) {
      return state_derivative<double>(*model, DisturbanceSwitches{}, env, s, w);
    };
    const int n = static_cast<int>(std::lround(t_end / dt));
    for (int k = 0; k < n; ++k) x = integrate_step(method, x, dt, f);
    return x;
  }
};

TEST(Convergence, Rk4IsFourthOrder) {
  const Problem p;
  const double t_end = 0.5;
  const StateVector ref = p.solve(Integrator::kRk4, 0.01 / 64 / 4, t_end);
  const double e1 = (p.solve(Integrator::kRk4, 0.01, t_end) - ref).norm();
  const double e2 = (p.solve(Integrator::kRk4, 0.005, t_end) - ref).norm();
  const double e3 = (p.solve(Integrator::kRk4, 0.0025, t_end) - ref).norm();
  EXPECT_GT(e1 / e2, 14.0);
  EXPECT_LT(e1 / e2, 18.0);
  EXPECT_GT(e2 / e3, 14.0);
  EXPECT_LT(e2 / e3, 18.0);
}

TEST(Convergence, EulerIsFirstOrder) {
  const Problem p;
  const double t_end = 0.5;
  const StateVector ref = p.solve(Integrator::kRk4, 0.0005, t_end);
  const double e1 = (p.solve(Integrator::kEuler, 0.002, t_end) - ref).norm();
  const double e2 = (p.solve(Integrator::kEuler, 0.001, t_end) - ref).norm();
  const double e3 = (p.solve(Integrator::kEuler, 0.0005, t_end) - ref).norm();
  EXPECT_GT(e1 / e2, 1.8);
  EXPECT_LT(e1 / e2, 2.2);
  EXPECT_GT(e2 / e3, 1.8);
  EXPECT_LT(e2 / e3, 2.2);
}

}  // namespace
}  // namespace dronetwin
