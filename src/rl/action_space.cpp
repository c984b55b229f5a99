// Action boxes of the RL action modes (rl/action_space.hpp).
#include "dronetwin/rl/action_space.hpp"

#include <algorithm>
#include <cmath>

namespace dronetwin::rl {

ActionBox action_box(const VehicleModel& m, const EnvConfig& config) {
  ActionBox box;
  const int rotors = m.num_rotors();
  double max_thrust_N = 0.0;
  for (int i = 0; i < rotors; ++i) max_thrust_N += m.rotor(i).thrust(m.rotor(i).max_speed_rad_s);
  // A narrower thrust box centres a normalised action of 0 near hover (RL exploration starts
  // from a hovering vehicle rather than one climbing at full authority).
  if (config.max_thrust_to_weight > 0.0) {
    max_thrust_N = std::min(max_thrust_N, config.max_thrust_to_weight * m.mass_kg() *
                                              config.sim.environment.gravity_W_m_s2.norm());
  }
  const auto add = [&](double lo, double hi) {
    box.low.push_back(lo);
    box.high.push_back(hi);
  };
  const Vec3 arena_min =
      config.task == Task::kRacing ? config.track.arena_min_m : config.arena_min_m;
  const Vec3 arena_max =
      config.task == Task::kRacing ? config.track.arena_max_m : config.arena_max_m;
  switch (config.action) {
    case ActionMode::kRelativePosition:
      for (int k = 0; k < 3; ++k) add(-config.relative_scale_m[k], config.relative_scale_m[k]);
      break;
    case ActionMode::kGlobalPosition:
      for (int k = 0; k < 3; ++k) add(arena_min[k], arena_max[k]);
      add(-M_PI, M_PI);
      break;
    case ActionMode::kRotorSpeeds:
      for (int i = 0; i < rotors; ++i) add(m.rotor(i).min_speed_rad_s, m.rotor(i).max_speed_rad_s);
      break;
    case ActionMode::kCtbr:
      add(0.0, max_thrust_N);
      for (int k = 0; k < 3; ++k)
        add(-config.max_body_rate_rad_s[k], config.max_body_rate_rad_s[k]);
      break;
    case ActionMode::kGeneralizedForce: {
      // Moments: what half of every rotor's thrust range, used differentially, gives about each
      // axis (sum over rotors of |A_k,i| T_max,i / 2, A the allocation matrix).
      add(0.0, max_thrust_N);
      const AllocationMatrix& A = m.allocation_matrix();
      for (int k = 1; k < 4; ++k) {
        double tau = 0.0;
        for (int i = 0; i < rotors; ++i)
          tau += std::abs(A(k, i)) * m.rotor(i).thrust(m.rotor(i).max_speed_rad_s) / 2.0;
        add(-tau, tau);
      }
      break;
    }
  }
  return box;
}

}  // namespace dronetwin::rl
