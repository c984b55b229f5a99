// Observation rows (rl/observation.hpp).
#include "dronetwin/rl/observation.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "dronetwin/math/quaternion.hpp"

namespace dronetwin::rl {

int piece_size(ObservationPiece piece, int action_size, int num_rotors, int gate_lookahead) {
  switch (piece) {
    case ObservationPiece::kPosition:
    case ObservationPiece::kVelocity:
    case ObservationPiece::kBodyRates:
    case ObservationPiece::kTargetRelative:
    case ObservationPiece::kTargetVelocity:
      return 3;
    case ObservationPiece::kRotation:
      return 9;
    case ObservationPiece::kQuaternion:
      return 4;
    case ObservationPiece::kPreviousAction:
      return action_size;
    case ObservationPiece::kGateCorners:
      return 12 * gate_lookahead;
    case ObservationPiece::kRotorSpeeds:
      return num_rotors;
  }
  return 0;
}

std::vector<PieceSlice> observation_layout(const std::vector<ObservationPiece>& pieces,
                                           int action_size, int num_rotors, int gate_lookahead) {
  std::vector<PieceSlice> layout;
  int offset = 0;
  for (const ObservationPiece p : pieces) {
    const int size = piece_size(p, action_size, num_rotors, gate_lookahead);
    layout.push_back({p, offset, size});
    offset += size;
  }
  return layout;
}

template <class O>
void write_observation(const std::vector<PieceSlice>& layout, const ObservationInput& in, O* row) {
  const Vec3& p = in.position_m;
  for (const PieceSlice& slice : layout) {
    O* out = row + slice.offset;
    switch (slice.piece) {
      case ObservationPiece::kPosition:
        for (int k = 0; k < 3; ++k) out[k] = static_cast<O>(p[k]);
        break;
      case ObservationPiece::kVelocity:
        for (int k = 0; k < 3; ++k) out[k] = static_cast<O>(in.velocity_m_s[k]);
        break;
      case ObservationPiece::kRotation: {
        // B_I R = R^T: row i of it is column i of R.
        // A zero quaternion (never produced by the physics, but a caller may hand one over)
        // reads as no rotation rather than NaN.
        const double norm = in.quaternion.norm();
        const Vec4 q = norm > 0.0 && std::isfinite(norm) ? Vec4(in.quaternion / norm)
                                                         : Vec4(1.0, 0.0, 0.0, 0.0);
        const Mat3 R = math::rotation_matrix<double>(q);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) out[3 * i + j] = static_cast<O>(R(j, i));
        break;
      }
      case ObservationPiece::kQuaternion:
        for (int k = 0; k < 4; ++k) out[k] = static_cast<O>(in.quaternion[k]);
        break;
      case ObservationPiece::kBodyRates:
        for (int k = 0; k < 3; ++k) out[k] = static_cast<O>(in.body_rates_rad_s[k]);
        break;
      case ObservationPiece::kPreviousAction:
        for (int i = 0; i < slice.size; ++i) out[i] = static_cast<O>(in.previous_action[i]);
        break;
      case ObservationPiece::kGateCorners: {
        const Track& track = *in.track;
        const int num_gates = static_cast<int>(track.gates.size());
        for (int k = 0; k < in.gate_lookahead; ++k) {
          int g = in.next_gate + k;
          g = track.closed ? g % num_gates : std::min(g, num_gates - 1);
          const std::array<Vec3, 4> corners = track.gates[static_cast<std::size_t>(g)].corners();
          for (int c = 0; c < 4; ++c)
            for (int i = 0; i < 3; ++i)
              out[12 * k + 3 * c + i] =
                  static_cast<O>(corners[static_cast<std::size_t>(c)][i] - p[i]);
        }
        break;
      }
      case ObservationPiece::kRotorSpeeds:
        for (int i = 0; i < slice.size; ++i) out[i] = static_cast<O>(in.rotor_speed_fraction[i]);
        break;
      case ObservationPiece::kTargetRelative:
        for (int k = 0; k < 3; ++k) out[k] = static_cast<O>(in.target_m[k] - p[k]);
        break;
      case ObservationPiece::kTargetVelocity:
        for (int k = 0; k < 3; ++k)
          out[k] = static_cast<O>(in.target_velocity_m_s[k] - in.velocity_m_s[k]);
        break;
    }
  }
}

template void write_observation<float>(const std::vector<PieceSlice>&, const ObservationInput&,
                                       float*);
template void write_observation<double>(const std::vector<PieceSlice>&, const ObservationInput&,
                                        double*);

}  // namespace dronetwin::rl
