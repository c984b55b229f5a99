// The time-optimal lap: the solution obeys the physics step it was solved with (re-flown interval
// by interval with the simulator's own step at a finer dt), keeps every rotor within its speed
// limits and the vehicle's centre inside every gate opening shrunk by the margin, closes the lap
// on itself, is faster than the fastest feasible minimum-snap lap on the same model, drives the
// rotors to their limits, comes back no slower when given as a flight to start from, is
// deterministic, and refuses bad input by name.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <string>

#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/time_optimal/time_optimal_lap.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::error_of;

std::shared_ptr<const VehicleModel> qdrone2() {
  static const auto model = test::load_model("qdrone2");
  return model;
}

const Track& circuit() {
  static const Track track = load_track(test::source_path("config/tracks/circuit.yaml"));
  return track;
}

/// One warm start (the minimum-snap plan flown at 0.6 of its feasible segment times) and 120
/// intervals: a few seconds in a release build; the default options' full search is measured in
/// docs/performance.md.
TimeOptimalOptions quick_options() {
  TimeOptimalOptions o;
  o.intervals = 120;
  o.warm_start_time_factors = {0.6};
  return o;
}

const TimeOptimalLap& quick_lap() {
  static const TimeOptimalLap lap = solve_time_optimal_lap(circuit(), *qdrone2(), quick_options());
  return lap;
}

/// Largest position gap between each node and the previous node re-flown over its interval by
/// the simulator's physics step (force_kernel.hpp's held_rotor_step) at dt / fine_steps.
double reflown_gap_m(const TimeOptimalLap& lap, const VehicleModel& model,
                     const DisturbanceSwitches& switches, int fine_steps) {
  const ForceKernel<double> kernel(model, ForceTerms::of(switches));
  double worst = 0.0;
  for (std::size_t k = 0; k + 1 < lap.states.size(); ++k) {
    const double dt_s = (lap.times_s[k + 1] - lap.times_s[k]) / fine_steps;
    StateVector x = lap.states[k];
    for (int i = 0; i < fine_steps; ++i)
      x = held_rotor_step<double>(kernel, Integrator::kRk4, x, lap.rotor_speeds_rad_s[k],
                                  Vec3::Zero(), Vec3(0.0, 0.0, -9.81), dt_s);
    worst = std::max(worst, (x.head<3>() - lap.states[k + 1].head<3>()).norm());
  }
  return worst;
}

/// The fraction of rotor-speed samples within 1 % of the speed range of a limit.
double saturated_fraction(const TimeOptimalLap& lap, const VehicleModel& model) {
  int saturated = 0, total = 0;
  for (const RotorVector& u : lap.rotor_speeds_rad_s) {
    for (int r = 0; r < model.num_rotors(); ++r) {
      const double lo = model.rotor(r).min_speed_rad_s, hi = model.rotor(r).max_speed_rad_s;
      const double band = 0.01 * (hi - lo);
      saturated += (u[r] < lo + band || u[r] > hi - band) ? 1 : 0;
      ++total;
    }
  }
  return static_cast<double>(saturated) / total;
}

TEST(TimeOptimalLap, FlyingLapObeysThePhysicsTheRotorLimitsAndTheGates) {
  const TimeOptimalLap& lap = quick_lap();
  const VehicleModel& model = *qdrone2();
  std::cout << "flying lap: " << lap.lap_time_s << " s from a flown " << lap.warm_start_lap_time_s
            << " s (minimum snap " << lap.warm_start.lap_time_s << " s), violation "
            << lap.max_violation << ", " << lap.outer_iterations << " outer / "
            << lap.inner_iterations << " inner, " << lap.solve_time_s << " s, saturated "
            << saturated_fraction(lap, model) << "\n";
  ASSERT_TRUE(lap.converged) << lap.max_violation;
  EXPECT_LE(lap.max_violation, quick_options().constraint_tolerance);
  ASSERT_EQ(lap.states.size(), lap.times_s.size());
  ASSERT_EQ(lap.rotor_speeds_rad_s.size() + 1, lap.states.size());
  for (std::size_t k = 0; k < lap.rotor_speeds_rad_s.size(); ++k) {
    for (int r = 0; r < model.num_rotors(); ++r) {
      EXPECT_GE(lap.rotor_speeds_rad_s[k][r], model.rotor(r).min_speed_rad_s) << k << " " << r;
      EXPECT_LE(lap.rotor_speeds_rad_s[k][r], model.rotor(r).max_speed_rad_s) << k << " " << r;
    }
  }
  // Every gate in its plane, inside the opening less the margin (to the solver's tolerance);
  // the last gate's node is the lap's end (and start).
  const Track& track = circuit();
  ASSERT_EQ(lap.gate_nodes.size(), track.gates.size());
  EXPECT_EQ(static_cast<std::size_t>(lap.gate_nodes.back()), lap.states.size() - 1);
  EXPECT_GT(lap.gate_margin_m, 0.0);  // the collision shape's bounding radius
  for (std::size_t g = 0; g < track.gates.size(); ++g) {
    const Gate& gate = track.gates[g];
    const Vec3 d =
        lap.states[static_cast<std::size_t>(lap.gate_nodes[g])].head<3>() - gate.center_m;
    EXPECT_NEAR(d.dot(gate.normal()), 0.0, 1e-5) << gate.name;
    EXPECT_LE(std::abs(d.dot(gate.width_axis())), 0.5 * gate.width_m - lap.gate_margin_m + 1e-5)
        << gate.name;
    EXPECT_LE(std::abs(d.dot(gate.up_axis())), 0.5 * gate.height_m - lap.gate_margin_m + 1e-5)
        << gate.name;
  }
  // The lap ends in the state it started in.
  const StateVector& first = lap.states.front();
  const StateVector& last = lap.states.back();
  EXPECT_LT((last.head<3>() - first.head<3>()).norm(), 1e-5);
  EXPECT_LT(
      (last.segment<3>(state_index::kVelocity) - first.segment<3>(state_index::kVelocity)).norm(),
      1e-5);
  EXPECT_LT((last.segment<3>(state_index::kAngularVelocity) -
             first.segment<3>(state_index::kAngularVelocity))
                .norm(),
            1e-4);
  // The segment times add up to the lap, and the node times to it too.
  double sum_s = 0.0;
  for (double t : lap.segment_times_s) sum_s += t;
  EXPECT_NEAR(sum_s, lap.lap_time_s, 1e-12);
  EXPECT_NEAR(lap.times_s.back(), lap.lap_time_s, 1e-9);
  // The nodes obey the physics: re-flown at a twentieth of the step, every interval lands within
  // the RK4 error of the solver's own two substeps (fifth order locally).
  EXPECT_LT(reflown_gap_m(lap, model, quick_options().switches, 20), 1e-3);
}

TEST(TimeOptimalLap, BeatsTheFastestFeasibleMinimumSnapLapAndDrivesTheRotorsToTheirLimits) {
  // The minimum-snap lap slowed until its flat rotor speeds are within limits flies the gate
  // centres with every rotor inside its range; the time-optimal lap of the same circuit, with
  // the drag terms that only slow it down, must be faster, and with a thrust-to-weight of about
  // 7 by a wide margin.
  const TimeOptimalLap& lap = quick_lap();
  EXPECT_LT(lap.lap_time_s, 0.8 * lap.warm_start.lap_time_s);
  EXPECT_LT(lap.lap_time_s, lap.warm_start_lap_time_s);
  // A minimum-time lap of a control-affine system is bang-bang away from singular arcs
  // (Pontryagin): the rotors use their whole range, both limits. (How much of the lap sits on a
  // limit is reported, not asserted: the solve is local, docs/planning.md.)
  const VehicleModel& model = *qdrone2();
  double fastest = 0.0, slowest = 1e9;
  for (const RotorVector& u : lap.rotor_speeds_rad_s) {
    fastest = std::max(fastest, u.maxCoeff());
    slowest = std::min(slowest, u.minCoeff());
  }
  EXPECT_GT(fastest, 0.99 * model.rotor(0).max_speed_rad_s);
  EXPECT_LT(slowest, 0.01 * model.rotor(0).max_speed_rad_s);
}

TEST(TimeOptimalLap, ComesBackNoSlowerFromItsOwnLapAsAFlight) {
  // The solved lap flown twice over, recorded ten times per interval (each interval re-flown
  // from its node with its rotor speeds held), is a warm start that is feasible already: the
  // solve from it keeps it or improves on it.
  const TimeOptimalLap& lap = quick_lap();
  const VehicleModel& model = *qdrone2();
  const ForceKernel<double> kernel(model, ForceTerms::of(quick_options().switches));
  constexpr int kSamples = 10;
  FlownTrajectory flight;
  for (int round = 0; round < 2; ++round) {
    for (std::size_t k = 0; k + 1 < lap.states.size(); ++k) {
      const double dt_s = (lap.times_s[k + 1] - lap.times_s[k]) / kSamples;
      StateVector x = lap.states[k];
      for (int i = 0; i < kSamples; ++i) {
        flight.times_s.push_back(round * lap.lap_time_s + lap.times_s[k] + i * dt_s);
        flight.states.push_back(x);
        flight.rotor_speeds_rad_s.push_back(lap.rotor_speeds_rad_s[k]);
        x = held_rotor_step<double>(kernel, Integrator::kRk4, x, lap.rotor_speeds_rad_s[k],
                                    Vec3::Zero(), Vec3(0.0, 0.0, -9.81), dt_s);
      }
    }
  }
  flight.times_s.push_back(2.0 * lap.lap_time_s);
  flight.states.push_back(lap.states.back());
  flight.rotor_speeds_rad_s.push_back(lap.rotor_speeds_rad_s.back());
  // On the lap's own grid (intervals per segment from its gate nodes).
  TimeOptimalOptions same_grid = quick_options();
  int previous_node = 0;
  for (const int node : lap.gate_nodes) {
    same_grid.intervals_per_segment.push_back(node - previous_node);
    previous_node = node;
  }
  const TimeOptimalLap again = solve_time_optimal_lap(circuit(), *qdrone2(), same_grid, flight);
  std::cout << "from its own lap: " << again.lap_time_s << " s from " << lap.lap_time_s << " s\n";
  ASSERT_TRUE(again.converged) << again.max_violation;
  EXPECT_NEAR(again.warm_start_lap_time_s, lap.lap_time_s, 1e-9);
  EXPECT_LE(again.lap_time_s, lap.lap_time_s * (1.0 + 1e-3));
}

TEST(TimeOptimalLap, IsDeterministic) {
  TimeOptimalOptions o = quick_options();
  o.max_outer_iterations = 3;  // the feasible lap and two attempts to shorten it
  const TimeOptimalLap a = solve_time_optimal_lap(circuit(), *qdrone2(), o);
  const TimeOptimalLap b = solve_time_optimal_lap(circuit(), *qdrone2(), o);
  EXPECT_EQ(a.lap_time_s, b.lap_time_s);
  ASSERT_EQ(a.states.size(), b.states.size());
  for (std::size_t k = 0; k < a.states.size(); ++k) EXPECT_EQ(a.states[k], b.states[k]) << k;
}

TEST(TimeOptimalLap, RefusesBadOptionsAndTracksByName) {
  const VehicleModel& model = *qdrone2();
  Track empty = circuit();
  empty.gates.clear();
  EXPECT_NE(error_of([&] { solve_time_optimal_lap(empty, model, {}); }).find("has no gates"),
            std::string::npos);
  Track open = circuit();
  open.closed = false;
  EXPECT_NE(error_of([&] { solve_time_optimal_lap(open, model, {}); })
                .find("a flying lap needs a closed track with at least 2 gates; track 'circuit' "
                      "is open"),
            std::string::npos);
  TimeOptimalOptions o;
  o.intervals = 3;
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o);
            }).find("intervals: expected in [4 x gates = 32, 100000], got 3"),
            std::string::npos);
  o = {};
  o.substeps = 0;
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o);
            }).find("substeps: expected in [1, 100], got 0"),
            std::string::npos);
  o = {};
  o.warm_start_rhos = {1.0, -2.0};
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o);
            }).find("warm_start_rhos[1]: expected > 0, got -2"),
            std::string::npos);
  o = {};
  o.warm_start_time_factors = {1.0, 0.0};
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o);
            }).find("warm_start_time_factors[1]: expected in [0.1, 10], got 0"),
            std::string::npos);
  // Each refusal of validate(), with the option's name and value.
  const auto refused = [&](const TimeOptimalOptions& bad, const std::string& expected) {
    EXPECT_NE(error_of([&] { solve_time_optimal_lap(circuit(), model, bad); }).find(expected),
              std::string::npos)
        << expected;
  };
  o = {};
  o.gravity_m_s2 = 0.0;
  refused(o, "gravity_m_s2: expected > 0, got 0");
  o = {};
  o.gate_margin_m = std::nan("");
  refused(o, "gate_margin_m: expected finite, got nan");
  o = {};
  o.warm_start_rhos.clear();
  refused(o, "warm_start_rhos: expected at least one");
  o = {};
  o.warm_start_time_factors.clear();
  refused(o, "warm_start_time_factors: expected at least one");
  o = {};
  o.constraint_tolerance = -1.0;
  refused(o, "constraint_tolerance: expected > 0, got -1");
  o = {};
  o.max_inner_iterations = 0;
  refused(o, "max_outer_iterations and max_inner_iterations: expected >= 1, got 40 and 0");
  o = {};
  o.intervals_per_segment = {20, 20};
  refused(o,
          "intervals_per_segment: expected one count per segment (8 for the gates of "
          "'circuit'), got 2");
  o.intervals_per_segment.assign(8, 20);
  o.intervals_per_segment[5] = 3;
  refused(o, "intervals_per_segment[5]: expected a count in [4, 100000], got 3");
  o = {};
  o.gate_margin_m = 0.8;
  EXPECT_NE(error_of([&] { solve_time_optimal_lap(circuit(), model, o); })
                .find("gate 0 ('g1') opening 1.5 m x 1.5 m: expected wider than twice the "
                      "margin of 0.8"),
            std::string::npos);
}

TEST(TimeOptimalLap, RefusesABadFlightByIndex) {
  const VehicleModel& model = *qdrone2();
  const TimeOptimalOptions o = quick_options();
  StateVector hover = StateVector::Zero();
  hover[state_index::kQuaternion] = 1.0;
  const RotorVector speeds = model.hover_speeds_rad_s();
  FlownTrajectory f;
  for (int i = 0; i < 3; ++i) {
    f.times_s.push_back(0.01 * i);
    f.states.push_back(hover);
    f.rotor_speeds_rad_s.push_back(speeds);
  }
  FlownTrajectory bad;
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, bad);
            }).find("flown warm start: expected at least 2 samples, got 0"),
            std::string::npos);
  bad = f;
  bad.times_s[2] = bad.times_s[1];
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, bad);
            }).find("times_s[2]: expected finite and above the one before, got 0.01"),
            std::string::npos);
  bad = f;
  bad.states[1][state_index::kVelocity] = std::nan("");
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, bad);
            }).find("states[1]: expected finite numbers"),
            std::string::npos);
  bad = f;
  bad.rotor_speeds_rad_s.pop_back();
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, bad);
            }).find("expected 3 states and rotor speeds (one per time), got 3 and 2"),
            std::string::npos);
  bad = f;
  bad.rotor_speeds_rad_s[0] = RotorVector(3);
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, bad);
            }).find("rotor_speeds_rad_s[0]: expected 4 finite numbers, got 3"),
            std::string::npos);
  // A hover goes through no gate.
  EXPECT_NE(error_of([&] {
              solve_time_optimal_lap(circuit(), model, o, f);
            }).find("no full lap through the 8 gates of 'circuit'"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
