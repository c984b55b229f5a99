#pragma once
// Rotor faults (docs/faults.md): from a given time on, a rotor
//   - loses effectiveness: it makes `effectiveness` times its thrust, and the moments proportional
//     to the thrust (yaw reaction, drag moment, ground effect) scale with it (a chipped or loose
//     propeller); its speed, drag and gyroscopic terms are unchanged;
//   - stops: its motor's reference becomes zero, so it spins down with its motor lag;
//   - sticks: its speed stays what it was when the fault began, whatever the reference.
// The controller flying the vehicle is not told. Settings are plain data (SimConfig::faults).
//
//   SimConfig c;
//   c.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, /*rotor=*/0, /*start_s=*/10.0,
//                                  /*effectiveness=*/0.5};
//   c.faults.num_rotor_faults = 1;
//
// A fault acts from the first physics step whose start time t satisfies t >= start_s - dt / 2
// (the step nearest its start).

#include <array>
#include <cstdint>
#include <string_view>

namespace dronetwin {

enum class RotorFaultKind { kEffectiveness, kStop, kStuck };

/// YAML and Python names, in the order of RotorFaultKind.
inline constexpr std::array<std::string_view, 3> kRotorFaultNames = {"rotor_effectiveness",
                                                                     "rotor_stop", "rotor_stuck"};

struct RotorFault {
  RotorFaultKind kind = RotorFaultKind::kEffectiveness;
  int rotor = 0;
  double start_s = 0.0;
  /// kEffectiveness: the fraction of its thrust the rotor still makes, in [0, 1].
  double effectiveness = 1.0;

  /// True from the step nearest start_s on (the step starting at `time_s`, of length `dt_s`).
  bool active_at(double time_s, double dt_s) const { return time_s >= start_s - 0.5 * dt_s; }
};

/// Faults held in a fixed array so that the settings stay plain data.
inline constexpr int kMaxRotorFaults = 8;

struct FaultSettings {
  std::array<RotorFault, kMaxRotorFaults> rotor{};
  int num_rotor_faults = 0;

  bool any() const { return num_rotor_faults > 0; }
  /// The lost-effectiveness faults in the order they begin (ties in list order), into `order`;
  /// returns how many. Their thrust scalings compose in this order, so a vehicle with the first
  /// n of them acting is the same however many vehicles or lanes fly it. No allocation.
  int effectiveness_order(std::array<int, kMaxRotorFaults>& order) const {
    int n = 0;
    for (int j = 0; j < num_rotor_faults; ++j) {
      if (rotor[static_cast<std::size_t>(j)].kind != RotorFaultKind::kEffectiveness) continue;
      // Insertion by start time after every earlier fault that starts no later.
      int k = n++;
      for (; k > 0 &&
             rotor[static_cast<std::size_t>(order[static_cast<std::size_t>(k - 1)])].start_s >
                 rotor[static_cast<std::size_t>(j)].start_s;
           --k)
        order[static_cast<std::size_t>(k)] = order[static_cast<std::size_t>(k - 1)];
      order[static_cast<std::size_t>(k)] = j;
    }
    return n;
  }
  /// Bit j set when rotor fault j acts on the step starting at `time_s`.
  std::uint32_t active_at(double time_s, double dt_s) const {
    std::uint32_t mask = 0;
    for (int j = 0; j < num_rotor_faults; ++j)
      if (rotor[static_cast<std::size_t>(j)].active_at(time_s, dt_s)) mask |= 1u << j;
    return mask;
  }
};

}  // namespace dronetwin
