#pragma once
// One observation row: the pieces of ObservationPiece in a layout's order, from one vehicle's
// measured state and its task context. VecEnv writes every env's row with it, and a deployed
// policy (policy/policy_controller.hpp) builds its row with it too, so that a policy sees in
// flight exactly what it saw in training (docs/rl.md, "Observations").
//
//   std::vector<PieceSlice> layout = observation_layout(pieces, action_size, rotors, lookahead);
//   ObservationInput in;  in.position_m = p;  ...
//   write_observation(layout, in, row.data());

#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/rl/env_config.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin::rl {

/// Where one observation piece sits in an observation row.
struct PieceSlice {
  ObservationPiece piece;
  int offset = 0;
  int size = 0;
};

/// Values of one piece: 3 for vectors, 9 for the rotation, 4 for the quaternion, the action size,
/// 12 per gate looked ahead, one per rotor.
int piece_size(ObservationPiece piece, int action_size, int num_rotors, int gate_lookahead);

/// The pieces laid out one after the other.
std::vector<PieceSlice> observation_layout(const std::vector<ObservationPiece>& pieces,
                                           int action_size, int num_rotors, int gate_lookahead);

/// Everything a row is made of. Pointers are read only for the pieces that need them.
struct ObservationInput {
  Vec3 position_m = Vec3::Zero();  ///< measured, world frame
  Vec3 velocity_m_s = Vec3::Zero();
  Vec4 quaternion = Vec4(1.0, 0.0, 0.0, 0.0);  ///< [w, x, y, z], body to world (normalised here)
  Vec3 body_rates_rad_s = Vec3::Zero();
  /// The previous action as the policy gave it (normalised with normalized_actions), action size.
  const double* previous_action = nullptr;
  /// w_i / max_speed_i, one per rotor.
  const double* rotor_speed_fraction = nullptr;
  /// Racing: the track and the index of the next gate (counting on past the last one of a lap).
  const Track* track = nullptr;
  int next_gate = 0;
  int gate_lookahead = 0;
  Vec3 target_m = Vec3::Zero();  ///< hover setpoint, trajectory point or next gate centre
  Vec3 target_velocity_m_s = Vec3::Zero();
};

/// Writes the row of `layout` (its last slice's end values) to `row`.
template <class O>
void write_observation(const std::vector<PieceSlice>& layout, const ObservationInput& in, O* row);

extern template void write_observation<float>(const std::vector<PieceSlice>&,
                                              const ObservationInput&, float*);
extern template void write_observation<double>(const std::vector<PieceSlice>&,
                                               const ObservationInput&, double*);

}  // namespace dronetwin::rl
