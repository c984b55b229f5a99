// The simulator's per-step factorisation (HeldRotorWrench) must equal the term-by-term model
// (accumulate_wrench) exactly up to rounding, for every combination of switches and at random
// states, on a quad, a hexa and a tilted-rotor layout.

#include <gtest/gtest.h>

#include "dronetwin/dynamics/held_rotor_wrench.hpp"
#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

class HeldRotorWrenchTest : public ::testing::TestWithParam<const char*> {};

TEST_P(HeldRotorWrenchTest, MatchesTheTermByTermModel) {
  const auto model = test::load_model(GetParam());
  Random rng(7);
  Environment env;
  for (int mask = 0; mask < 64; ++mask) {
    DisturbanceSwitches sw{(mask & 1) != 0, (mask & 2) != 0,  (mask & 4) != 0,
                           (mask & 8) != 0, (mask & 16) != 0, (mask & 32) != 0};
    HeldRotorWrench held;
    held.configure(*model, sw);
    for (int trial = 0; trial < 5; ++trial) {
      // Low states too, so the ground-effect floor is exercised.
      const StateVector x = test::random_state(rng, 0.0, 1.0);
      RotorVector w(model->num_rotors());
      for (int i = 0; i < w.size(); ++i) w[i] = 3000.0 * rng.uniform();
      env.wind_W_m_s << rng.uniform() - 0.5, rng.uniform() - 0.5, 0.2 * rng.uniform();
      held.prepare(*model, w);
      const StateVector fast = held.derivative(*model, env, x);
      const StateVector reference = state_derivative<double>(*model, sw, env, x, w);
      const double scale = 1.0 + reference.norm();
      EXPECT_LT((fast - reference).norm(), 1e-12 * scale) << "switch mask " << mask;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Models, HeldRotorWrenchTest,
                         ::testing::Values("qdrone2", "hexarotor", "tilted_hexarotor"));

}  // namespace
}  // namespace dronetwin
