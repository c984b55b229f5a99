// The RL vector env (rl/vec_env.hpp): spaces and the Eq. 4.18 observation, the reward terms
// against a hand computation from the states, auto-reset, crashes and their causes, gates,
// action modes, randomisation, determinism across threads and batch sizes, and bad input.

#include "dronetwin/rl/vec_env.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "dronetwin/world/gate.hpp"
#include "test_support.hpp"

namespace dronetwin::rl {
namespace {

EnvFile env_file(const std::string& name, const std::string& overrides = "") {
  return load_env_config(test::source_path("config/rl/" + name + ".yaml"), overrides);
}

template <class T = double>
VecEnv<T> make_env(const std::string& name, int n, const std::string& overrides = "",
                   int threads = 1) {
  EnvFile f = env_file(name, overrides);
  return VecEnv<T>(f.model, f.config, n, threads);
}

// Straight track (config/tracks/straight.yaml): gates along +x.
const std::string kStraight =
    "{racing: {track: ../tracks/straight.yaml, laps: 1}, episode_time_s: 20}";

TEST(VecEnvSpaces, RacingIsEquation418And419) {
  auto env = make_env("racing", 3);
  EXPECT_EQ(env.observation_size(), 45);           // Eq. 4.18
  EXPECT_EQ(env.action_size(), 3);                 // Eq. 4.19
  EXPECT_EQ(env.substeps(), 10);                   // 100 Hz over 1 kHz
  const std::vector<double> hi = {1.0, 1.0, 1.5};  // Sec. 4.4.1
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(env.action_high()[static_cast<std::size_t>(i)], hi[static_cast<std::size_t>(i)]);
    EXPECT_EQ(env.action_low()[static_cast<std::size_t>(i)], -hi[static_cast<std::size_t>(i)]);
  }
  const std::vector<std::pair<ObservationPiece, int>> expected = {
      {ObservationPiece::kPosition, 3},       {ObservationPiece::kVelocity, 3},
      {ObservationPiece::kRotation, 9},       {ObservationPiece::kBodyRates, 3},
      {ObservationPiece::kPreviousAction, 3}, {ObservationPiece::kGateCorners, 24}};
  ASSERT_EQ(env.observation_layout().size(), expected.size());
  int offset = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(env.observation_layout()[i].piece, expected[i].first);
    EXPECT_EQ(env.observation_layout()[i].offset, offset);
    EXPECT_EQ(env.observation_layout()[i].size, expected[i].second);
    offset += expected[i].second;
  }
  for (int i = 6; i < 15; ++i) {  // rotation entries
    EXPECT_EQ(env.observation_low()[static_cast<std::size_t>(i)], -1.0);
    EXPECT_EQ(env.observation_high()[static_cast<std::size_t>(i)], 1.0);
  }
}

// The first observation of an episode: the start pose, R^T, zero previous action, and the next
// two gates' corners relative to the vehicle, from the gate geometry written out by hand.
TEST(VecEnvObservation, ResetObservationIsTheStartPoseAndTheNextGatesCorners) {
  auto env = make_env("racing", 2, kStraight);
  const Track& track = env.config().track;
  const double* o = env.observation<double>();
  const Vec3 p = track.start_position_m;
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(o[k], p[k]);
    EXPECT_EQ(o[3 + k], 0.0);
  }
  // R^T of a yaw-only attitude: [[c, s, 0], [-s, c, 0], [0, 0, 1]].
  const double c = std::cos(track.start_yaw_rad), s = std::sin(track.start_yaw_rad);
  const double Rt[9] = {c, s, 0, -s, c, 0, 0, 0, 1};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(o[6 + i], Rt[i], 1e-15) << i;
  for (int i = 15; i < 21; ++i) EXPECT_EQ(o[i], 0.0);
  for (int g = 0; g < 2; ++g) {
    const Gate& gate = track.gates[static_cast<std::size_t>(g)];
    // Corners in the order (+y,+z), (-y,+z), (-y,-z), (+y,-z) of the gate's axes.
    const double sy[4] = {1, -1, -1, 1}, sz[4] = {1, 1, -1, -1};
    for (int k = 0; k < 4; ++k) {
      const Vec3 corner = gate.center_m + sy[k] * gate.width_m / 2 * gate.width_axis() +
                          sz[k] * gate.height_m / 2 * gate.up_axis();
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(o[21 + 12 * g + 3 * k + i], corner[i] - p[i], 1e-12) << g << " " << k;
    }
  }
}

// One step's reward, term by term, from the positions, action and body rate the env reports.
TEST(VecEnvReward, TermsMatchAHandComputationOfEquation420) {
  auto env = make_env("racing", 1, kStraight);
  const Vec3 c0 = env.config().track.gates[0].center_m;
  const auto pos = [&] { return env.batch().state(0).segment<3>(state_index::kPosition).eval(); };
  double a[3] = {0.4, -0.2, 0.3};
  for (int t = 0; t < 5; ++t) {
    const Vec3 p0 = pos();
    const Vec3 a_prev = t == 0 ? Vec3::Zero() : Vec3(0.4, -0.2, 0.3 - 0.05 * (t - 1));
    a[2] = 0.3 - 0.05 * t;
    env.step(a);
    const Vec3 p1 = pos();
    const Vec3 w = env.batch().state(0).segment<3>(state_index::kAngularVelocity);
    const double progress = (p0 - c0).norm() - (p1 - c0).norm();
    const double rate = (Vec3(a[0], a[1], a[2]) - a_prev).squaredNorm();
    const double* terms = env.reward_terms_data();
    EXPECT_DOUBLE_EQ(terms[0], 1.0 * progress);
    EXPECT_DOUBLE_EQ(terms[1], -1e-4 * rate);
    EXPECT_DOUBLE_EQ(terms[2], -2e-4 * w.norm());
    EXPECT_EQ(terms[3], 0.0);
    EXPECT_DOUBLE_EQ(env.reward_data()[0], terms[0] + terms[1] + terms[2] + terms[3]);
    EXPECT_FALSE(env.done_data()[0]);
    // Eq. 4.18: the previous action in the observation is the one just taken.
    for (int i = 0; i < 3; ++i) EXPECT_EQ(env.observation<double>()[18 + i], a[i]);
  }
  EXPECT_GT(env.batch().state(0)[0], env.config().track.start_position_m[0]);  // moving on
}

// A time limit truncates every env at once; the last observation goes to final_observation,
// the new episode starts at the task's start, and the statistics are reported.
TEST(VecEnvAutoReset, TimeLimitTruncatesAndRestartsInTheSameStep) {
  auto env = make_env("racing", 3, "{episode_time_s: 0.05}");
  const std::vector<double> zero(9, 0.0);
  for (int t = 0; t < 4; ++t) {
    env.step(zero.data());
    for (int e = 0; e < 3; ++e) ASSERT_FALSE(env.done_data()[e]);
  }
  const Vec3 before = env.batch().state(1).segment<3>(0);
  env.step(zero.data());
  const Vec3 start = env.config().track.start_position_m;
  for (int e = 0; e < 3; ++e) {
    EXPECT_TRUE(env.truncated_data()[e]);
    EXPECT_FALSE(env.terminated_data()[e]);
    EXPECT_EQ(env.end_cause_data()[e], static_cast<std::uint8_t>(EndCause::kTimeLimit));
    EXPECT_EQ(env.finished_length_data()[e], 5);
    EXPECT_EQ(env.episode_length_data()[e], 0);
    EXPECT_EQ(env.episode_index_data()[e], 1);
    const double* now = env.observation<double>() + 45 * e;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(now[k], start[k]);
  }
  // The final observation is where the vehicle was after step 5 (hovering near the start, not
  // exactly at it: the controller moved it).
  const double* last = env.final_observation<double>() + 45;
  (void)before;
  const Vec3 final_p(last[0], last[1], last[2]);
  EXPECT_NE(final_p, start);
  EXPECT_LT((final_p - start).norm(), 0.05);
}

// The auto-reset replaces the vehicle; the state and rotor speeds it reached are kept. An env
// whose episode is longer flies the same start and actions, so it holds them after that step.
TEST(VecEnvAutoReset, TheFinalStateIsWhatTheEndedEpisodeReached) {
  auto ending = make_env("racing", 3, "{episode_time_s: 0.05}");
  auto going_on = make_env("racing", 3, "{episode_time_s: 1}");
  const std::vector<double> zero(9, 0.0);
  for (int t = 0; t < 5; ++t) {
    ending.step(zero.data());
    going_on.step(zero.data());
  }
  const int num_rotors = ending.model().num_rotors();
  for (int e = 0; e < 3; ++e) {
    ASSERT_TRUE(ending.done_data()[e]);
    ASSERT_FALSE(going_on.done_data()[e]);
    const StateVector reached = going_on.batch().state(e);
    for (int k = 0; k < kStateSize; ++k)
      EXPECT_EQ(ending.final_state_data()[e * kStateSize + k], reached[k]) << "env " << e;
    EXPECT_NE(ending.batch().state(e), reached);  // the env itself starts again
    const RotorVector omega = going_on.batch().rotor_speeds(e);
    for (int r = 0; r < num_rotors; ++r)
      EXPECT_EQ(ending.final_rotor_speed_data()[e * num_rotors + r], omega[r]) << "env " << e;
  }
}

TEST(VecEnvTermination, FlyingIntoTheGroundIsACrashWithItsPenalty) {
  auto env = make_env("hover", 2,
                      "{hover: {target_m: [0, 0, 0.6], start_offset_m: [0, 0, 0]}, "
                      "randomization: {position_m: [0, 0, 0], velocity_m_s: [0, 0, 0], "
                      "attitude_rad: [0, 0, 0]}}");
  const double down[6] = {0, 0, -1.5, 0, 0, 0};  // env 0 dives, env 1 holds
  int steps = 0;
  while (!env.done_data()[0] && steps < 300) {
    env.step(down);
    ++steps;
    EXPECT_FALSE(env.done_data()[1]);
  }
  ASSERT_TRUE(env.done_data()[0]) << "no crash after " << steps << " steps";
  EXPECT_TRUE(env.terminated_data()[0]);
  EXPECT_EQ(env.end_cause_data()[0], static_cast<std::uint8_t>(EndCause::kGround));
  EXPECT_EQ(env.reward_terms_data()[3 * 2 + 0], -5.0);  // Eq. 4.21
  EXPECT_EQ(env.reward_terms_data()[3 * 2 + 1], 0.0);
  EXPECT_LT(steps, 100);  // 0.6 m at up to 1.5 m per 10 ms reference jump: well under 1 s
}

// A NaN action ends that env's episode with its cause; the other envs fly exactly as in a run
// where that env had a normal action.
TEST(VecEnvBadInput, ANanActionEndsOnlyItsEnv) {
  auto a = make_env("racing", 3);
  auto b = make_env("racing", 3);
  std::vector<double> act = {0.3, 0.1, 0.2, 0.3, 0.1, 0.2, -0.1, 0.2, 0.0};
  std::vector<double> bad = act;
  bad[3] = std::nan("");
  a.step(act.data());
  b.step(bad.data());
  EXPECT_FALSE(b.done_data()[0]);
  EXPECT_TRUE(b.terminated_data()[1]);
  EXPECT_EQ(b.end_cause_data()[1], static_cast<std::uint8_t>(EndCause::kInvalidAction));
  EXPECT_FALSE(b.done_data()[2]);
  for (int e : {0, 2}) {
    EXPECT_EQ(std::memcmp(a.observation<double>() + 45 * e, b.observation<double>() + 45 * e,
                          45 * sizeof(double)),
              0);
    EXPECT_EQ(a.reward_data()[e], b.reward_data()[e]);
  }
}

/// A simple pilot for the relative-position action: towards a point on the next gate's axis 1 m
/// ahead of the vehicle's projection onto it (at most 0.5 m past the gate), the step scaled
/// uniformly into the action box and then by 0.6 (about 3.5 m/s: the SE(3) loop's lateral
/// damping is light, and faster it overshoots the 45-degree turns of the circuit). Flies every
/// env for `steps` steps or until env 0's episode ends. `aim_offset` shifts the aim point.
template <class T>
void fly_at_gates(VecEnv<T>& env, int steps, const Vec3& aim_offset = Vec3::Zero()) {
  const int n = env.num_envs();
  const Vec3 box = env.config().relative_scale_m;
  std::vector<double> act(static_cast<std::size_t>(3 * n));
  for (int t = 0; t < steps; ++t) {
    for (int e = 0; e < n; ++e) {
      const Vec3 p = env.batch().state(e).template segment<3>(0);
      const Gate& g = env.config().track.gates[static_cast<std::size_t>(env.next_gate_data()[e])];
      const double along = g.normal().dot(p - g.center_m);
      Vec3 d = g.center_m + std::min(along + 1.0, 0.5) * g.normal() + aim_offset - p;
      const double fit = (box.array() / d.array().abs().max(1e-9)).minCoeff();
      d *= 0.6 * std::min(1.0, fit);
      for (int k = 0; k < 3; ++k) act[static_cast<std::size_t>(3 * e + k)] = d[k];
    }
    env.step(act.data());
    if (env.done_data()[0]) return;
  }
}

TEST(VecEnvGates, FlyingThroughEveryGateFinishesTheLap) {
  auto env = make_env("racing", 1, kStraight);
  const int gates = static_cast<int>(env.config().track.gates.size());
  fly_at_gates(env, 2000);
  ASSERT_TRUE(env.done_data()[0]);
  EXPECT_EQ(env.end_cause_data()[0], static_cast<std::uint8_t>(EndCause::kFinished));
  EXPECT_TRUE(env.terminated_data()[0]);
  EXPECT_EQ(env.finished_gates_data()[0], gates);
  EXPECT_EQ(env.finished_laps_data()[0], 1);
  EXPECT_GT(env.finished_best_lap_data()[0], 0.0);
  EXPECT_EQ(env.reward_terms_data()[3], 0.0);  // no crash penalty for finishing
}

TEST(VecEnvGates, AimingAtAFrameBarIsAGateFrameCrash) {
  auto env = make_env("racing", 1, kStraight);
  const Gate& g = env.config().track.gates[0];
  // The centre line of the +y bar.
  fly_at_gates(env, 2000, (g.width_m + g.frame_width_m) / 2 * g.width_axis());
  ASSERT_TRUE(env.done_data()[0]);
  EXPECT_EQ(env.end_cause_data()[0], static_cast<std::uint8_t>(EndCause::kGateFrame));
  EXPECT_EQ(env.finished_gates_data()[0], 0);
  EXPECT_EQ(env.reward_terms_data()[3], -5.0);
}

// The circuit is flyable gate by gate with the SE(3) inner loop: two laps of the shipped track.
TEST(VecEnvGates, TheCircuitCanBeLappedWithoutACrash) {
  auto env = make_env("racing", 1, "{racing: {laps: 2}, episode_time_s: 60}");
  fly_at_gates(env, 6000);
  ASSERT_TRUE(env.done_data()[0]);
  EXPECT_EQ(env.end_cause_data()[0], static_cast<std::uint8_t>(EndCause::kFinished))
      << kEndCauseNames[env.end_cause_data()[0]];
  EXPECT_EQ(env.finished_gates_data()[0], 2 * static_cast<int>(env.config().track.gates.size()));
  EXPECT_EQ(env.finished_laps_data()[0], 2);
  // The lap time cannot beat the track's length at the pilot's top speed (~6 m/s).
  EXPECT_GT(env.finished_best_lap_data()[0], env.config().track.length_m() / 6.0);
}

// With random start gates (the racing curriculum) a lap is every gate once, counted from the gate
// the episode starts before: starting before g4, one lap is g4 ... g8, g1 ... g3, not g4 ... g8.
TEST(VecEnvGates, ALapFromARandomStartGateIsEveryGateOnce) {
  for (int seed = 0; seed < 64; ++seed) {
    std::string overrides =
        "{racing: {laps: 1, random_start_gate: true}, episode_time_s: 60, seed: ";
    overrides += std::to_string(seed);
    overrides += "}";
    auto env = make_env("racing", 1, overrides);
    if (env.next_gate_data()[0] == 0) continue;  // this seed starts at g1: try the next
    fly_at_gates(env, 6000);
    ASSERT_TRUE(env.done_data()[0]);
    EXPECT_EQ(env.end_cause_data()[0], static_cast<std::uint8_t>(EndCause::kFinished))
        << kEndCauseNames[env.end_cause_data()[0]];
    EXPECT_EQ(env.finished_gates_data()[0], static_cast<int>(env.config().track.gates.size()));
    EXPECT_EQ(env.finished_laps_data()[0], 1);
    return;
  }
  FAIL() << "no seed in 0..63 started past g1";
}

// Each low-level action mode holds a hover with the action that means "hover" in it.
TEST(VecEnvActions, EveryModeHoldsHoverWithItsHoverAction) {
  for (const char* mode :
       {"rotor_speeds", "ctbr", "generalized_force", "global_position", "relative_position"}) {
    SCOPED_TRACE(mode);
    auto env = make_env("hover", 1,
                        std::string("{action: ") + mode +
                            ", hover: {start_offset_m: [0, 0, 0]}, randomization: {position_m: "
                            "[0, 0, 0], velocity_m_s: [0, 0, 0], attitude_rad: [0, 0, 0]}}");
    const VehicleModel& m = env.model();
    std::vector<double> a;
    const double thrust = m.hover_thrusts_N().sum();
    const std::string name(mode);
    if (name == "rotor_speeds") {
      const RotorVector w = m.hover_speeds_rad_s();
      a.assign(w.data(), w.data() + w.size());
    } else if (name == "ctbr" || name == "generalized_force") {
      a = {thrust, 0, 0, 0};
    } else if (name == "global_position") {
      const Vec3 t = env.target(0);
      a = {t[0], t[1], t[2], 0.0};
    } else {
      a = {0, 0, 0};
    }
    ASSERT_EQ(static_cast<int>(a.size()), env.action_size());
    const Vec3 start = env.batch().state(0).segment<3>(0);
    for (int t = 0; t < 50; ++t) {  // 0.5 s
      env.step(a.data());
      ASSERT_FALSE(env.done_data()[0]) << kEndCauseNames[env.end_cause_data()[0]];
    }
    // Open-loop modes drift with the aerodynamic moments; a few cm in 0.5 s.
    EXPECT_LT((env.batch().state(0).segment<3>(0) - start).norm(), 0.1);
  }
}

// An environment file's rotor faults act in every episode, from start_s after its reset (the
// batch's per-lane fault clock).
TEST(VecEnvFaults, ARotorFaultBeginsAgainInEveryEpisode) {
  auto env =
      make_env("hover", 2,
               "{action: rotor_speeds, faults: [{type: rotor_stop, rotor: 0, start_s: 0.3}], "
               "hover: {start_offset_m: [0, 0, 0]}, randomization: {position_m: [0, 0, 0], "
               "velocity_m_s: [0, 0, 0], attitude_rad: [0, 0, 0]}}");
  const RotorVector hover = env.model().hover_speeds_rad_s();
  std::vector<double> a;  // one row of hover speeds per env
  for (int e = 0; e < 2; ++e) a.insert(a.end(), hover.data(), hover.data() + hover.size());
  env.reset(1);
  const auto fly = [&](int steps) {
    for (int t = 0; t < steps; ++t) env.step(a.data());
  };
  fly(25);  // 0.25 s: not yet
  EXPECT_EQ(env.batch().rotor_speeds(0)[0], hover[0]);
  EXPECT_EQ(env.batch().rotor_speeds(1)[0], hover[0]);
  fly(15);  // 0.4 s: stopping
  EXPECT_LT(env.batch().rotor_speeds(0)[0], 0.8 * hover[0]);
  EXPECT_EQ(env.batch().rotor_speeds(0)[1], hover[1]);
  env.reset_env(0);  // a new episode for env 0 only: its rotor spins again until 0.3 s
  fly(10);
  EXPECT_EQ(env.batch().rotor_speeds(0)[0], hover[0]);
  EXPECT_LT(env.batch().rotor_speeds(1)[0], 0.5 * hover[0]);
}

// An environment file's battery: each env drains its own pack, and a new episode starts on a
// full one (the env's reset resets its lane).
TEST(VecEnvBattery, EveryEpisodeStartsOnAFullPack) {
  auto env = make_env("hover", 2,
                      "{action: rotor_speeds, battery: {capacity_Ah: 0.05, initial_soc: 0.9}, "
                      "hover: {start_offset_m: [0, 0, 0]}, randomization: {position_m: [0, 0, 0], "
                      "velocity_m_s: [0, 0, 0], attitude_rad: [0, 0, 0]}}");
  const RotorVector hover = env.model().hover_speeds_rad_s();
  std::vector<double> a;
  for (int e = 0; e < 2; ++e) a.insert(a.end(), hover.data(), hover.data() + hover.size());
  env.reset(1);
  EXPECT_EQ(env.batch().battery(0).soc, 0.9);
  for (int t = 0; t < 20; ++t) env.step(a.data());
  const double drawn = env.batch().battery(1).soc;
  EXPECT_LT(drawn, 0.9);
  EXPECT_GT(env.batch().battery(0).voltage_V, 0.0);
  env.reset_env(0);
  EXPECT_EQ(env.batch().battery(0).soc, 0.9);
  EXPECT_EQ(env.batch().battery(1).soc, drawn);
}

// With normalized_actions, a_n in [-1, 1] means lo + (a_n + 1) / 2 (hi - lo): the same flight as
// the physical action.
TEST(VecEnvActions, NormalizedActionsMapOntoTheBox) {
  auto phys = make_env("racing", 1);
  auto norm = make_env("racing", 1, "{normalized_actions: true}");
  const double a[3] = {0.5, -0.25, 0.75};
  const double an[3] = {0.5 / 1.0, -0.25 / 1.0, 0.75 / 1.5};
  for (int t = 0; t < 20; ++t) {
    phys.step(a);
    norm.step(an);
  }
  for (int k = 0; k < 13; ++k)
    EXPECT_NEAR(phys.batch().state(0)[k], norm.batch().state(0)[k], 1e-12) << k;
  // Clipping: beyond the box is the box's edge.
  auto clipped = make_env("racing", 1);
  auto edge = make_env("racing", 1);
  const double big[3] = {5.0, -7.0, 9.0}, at_edge[3] = {1.0, -1.0, 1.5};
  clipped.step(big);
  edge.step(at_edge);
  EXPECT_EQ(clipped.batch().state(0), edge.batch().state(0));
}

// max_thrust_to_weight narrows the thrust box to k m g: with k = 2 a normalised 0 is hover thrust
// for the nominal mass, and the flight equals the physical action m g.
TEST(VecEnvActions, ThrustToWeightBoxCentresHover) {
  const std::string quiet =
      ", hover: {start_offset_m: [0, 0, 0]}, randomization: {position_m: [0, 0, 0], "
      "velocity_m_s: [0, 0, 0], attitude_rad: [0, 0, 0]}}";
  auto norm = make_env("hover", 1,
                       "{action: ctbr, normalized_actions: true, max_thrust_to_weight: 2" + quiet);
  auto phys = make_env("hover", 1, "{action: ctbr, max_thrust_to_weight: 2" + quiet);
  const double weight_N = norm.model().mass_kg() * 9.81;
  EXPECT_DOUBLE_EQ(norm.action_high()[0], 2.0 * weight_N);
  EXPECT_EQ(norm.action_low()[0], 0.0);
  const double zero[4] = {0, 0, 0, 0}, hover[4] = {weight_N, 0, 0, 0};
  for (int t = 0; t < 20; ++t) {
    norm.step(zero);
    phys.step(hover);
  }
  for (int k = 0; k < 13; ++k)
    EXPECT_NEAR(norm.batch().state(0)[k], phys.batch().state(0)[k], 1e-12) << k;
  // Larger than the rotors can give: the rotors' total is the bound.
  auto wide = make_env("hover", 1, "{action: ctbr, max_thrust_to_weight: 1000}");
  auto full = make_env("hover", 1, "{action: ctbr}");
  EXPECT_EQ(wide.action_high()[0], full.action_high()[0]);
  try {
    (void)make_env("hover", 1, "{action: ctbr, max_thrust_to_weight: -1}");
    ADD_FAILURE() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("max_thrust_to_weight: expected a number >= 0"),
              std::string::npos)
        << e.what();
  }
}

TEST(VecEnvRandomization, ParametersAreDrawnPerEnvWithinTheirRanges) {
  auto env = make_env("hover", 64,
                      "{randomization: {mass_scale: [0.8, 1.2], thrust_scale: [0.9, 1.1], "
                      "wind_speed_max_m_s: 2.0}}");
  const double m0 = env.model().mass_kg();
  double lo = 1e9, hi = -1e9;
  for (int e = 0; e < 64; ++e) {
    const double m = env.batch().parameter(ModelParameter::kMass, e);
    EXPECT_GE(m, 0.8 * m0 - 1e-12);
    EXPECT_LE(m, 1.2 * m0 + 1e-12);
    lo = std::min(lo, m);
    hi = std::max(hi, m);
  }
  EXPECT_GT(hi - lo, 0.2 * m0);  // 64 uniform draws spread over most of the 0.4 m0 range
  // A curriculum change applies at the next reset.
  EnvConfig c = env.config();
  c.randomization.mass_scale = {1.5, 1.5};
  env.set_config(c);
  env.reset_env(3);
  EXPECT_DOUBLE_EQ(env.batch().parameter(ModelParameter::kMass, 3), 1.5 * m0);
  EXPECT_NE(env.batch().parameter(ModelParameter::kMass, 4), 1.5 * m0);
  EnvConfig bad = env.config();
  bad.action = ActionMode::kCtbr;
  EXPECT_THROW(env.set_config(bad), InvalidArgument);
}

/// Observations, rewards and flags of the first `n_compare` envs over a run with noise,
/// randomisation and auto-resets.
std::vector<double> run_for_determinism(int n, int threads, int n_compare,
                                        const std::string& more = "") {
  auto env = make_env("racing", n,
                      "{noise: true, episode_time_s: 0.3, randomization: {mass_scale: [0.9, 1.1],"
                      " position_m: [0.3, 0.3, 0.2], wind_speed_max_m_s: 1.0}" +
                          more + "}",
                      threads);
  env.reset(11);
  std::vector<double> out, act(static_cast<std::size_t>(3 * n));
  for (int t = 0; t < 70; ++t) {
    // The phase is rounded once, (t + 10 (e + k)) / 10 with an exact numerator, so its bits
    // cannot depend on which path of this loop (vectorised body or scalar remainder) computes
    // an env. With 0.1 t + e + k (two roundings, open to FMA contraction), a -march=native
    // build gave env 1 other actions at step 9 for n = 200 than for n = 5.
    for (int e = 0; e < n; ++e)
      for (int k = 0; k < 3; ++k)
        act[static_cast<std::size_t>(3 * e + k)] = 0.5 * std::sin((t + 10.0 * (e + k)) / 10.0);
    env.step(act.data());
    for (int e = 0; e < n_compare; ++e) {
      const double* o = env.observation<double>() + 45 * e;
      out.insert(out.end(), o, o + 45);
      out.push_back(env.reward_data()[e]);
      out.push_back(env.done_data()[e]);
    }
  }
  return out;
}

TEST(VecEnvDeterminism, BitwiseAcrossThreadsAndBatchSizes) {
  const std::vector<double> one = run_for_determinism(5, 1, 5);
  const std::vector<double> two = run_for_determinism(5, 2, 5);
  const std::vector<double> big = run_for_determinism(test::full_or_sanitized(200, 37), 2, 5);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(one.data(), big.data(), one.size() * sizeof(double)), 0);
}

// A wind field (shear, a gust, turbulence) in the env file: every env has its own gusts, drawn
// anew each episode from its counter stream, so the results stay bitwise across threads and
// batch sizes; and the wind changes the flight.
TEST(VecEnvDeterminism, AWindFieldKeepsThemBitwiseAcrossThreadsAndBatchSizes) {
  const std::string wind =
      ", wind: {shear: true, turbulence: moderate, "
      "gusts: [{start_s: 0.05, duration_s: 0.1, amplitude_m_s: [0, 2, 0]}]}";
  const std::vector<double> one = run_for_determinism(5, 1, 5, wind);
  const std::vector<double> two = run_for_determinism(5, 2, 5, wind);
  const std::vector<double> big = run_for_determinism(test::full_or_sanitized(40, 11), 2, 5, wind);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(one.data(), big.data(), one.size() * sizeof(double)), 0);
  const std::vector<double> calm = run_for_determinism(5, 1, 5);
  EXPECT_NE(std::memcmp(one.data(), calm.data(), one.size() * sizeof(double)), 0);
}

TEST(VecEnvBadInput, ConfigErrorsNameTheField) {
  const auto message = [](const std::string& overrides) {
    try {
      env_file("racing", overrides);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("{task: racin}").find("task"), std::string::npos);
  EXPECT_NE(message("{task: racin}").find("racing"), std::string::npos);
  EXPECT_NE(message("{observation: [position, velocty]}").find("observation[1]"),
            std::string::npos);
  EXPECT_NE(message("{action: warp}").find("action"), std::string::npos);
  EXPECT_NE(message("{randomization: {mass_scale: [1.2, 0.8]}}").find("randomization.mass_scale"),
            std::string::npos);
  EXPECT_NE(message("{reward: {progres: 1}}").find("progres"), std::string::npos);
  EXPECT_NE(message("{racing: {track: nowhere.yaml}}").find("racing.track"), std::string::npos);
  EXPECT_NE(message("{task: hover}").find("gate_corners"), std::string::npos);
  EXPECT_NE(message("{control_rate_hz: 300}").find("control_rate_hz"), std::string::npos);
  EXPECT_NE(message("{episode_time_s: -1}").find("episode_time_s"), std::string::npos);
}

}  // namespace
}  // namespace dronetwin::rl

namespace dronetwin::rl {
namespace {

// The trajectory task: acting on the observed target offset (target - p, the first piece)
// follows the thesis circle; the gate and distance terms, switched on, are their weights times
// the gates passed (none here) and the distance to the target.
TEST(VecEnvTrajectory, FollowingTheObservedOffsetTracksTheReference) {
  auto env = make_env("trajectory", 2, "{reward: {distance: -0.1, gate: 2.0}}");
  ASSERT_EQ(env.observation_layout()[0].piece, ObservationPiece::kTargetRelative);
  std::vector<double> act(6);
  double last_gap = 0.0;
  for (int t = 0; t < 300; ++t) {  // 3 s, beyond the first 0.5 s of catching up
    const double* o = env.observation<double>();
    for (int e = 0; e < 2; ++e)
      for (int k = 0; k < 3; ++k)
        act[static_cast<std::size_t>(3 * e + k)] =
            std::clamp(o[env.observation_size() * e + k], -1.0, 1.0);
    env.step(act.data());
    ASSERT_FALSE(env.done_data()[0]) << kEndCauseNames[env.end_cause_data()[0]];
    const Vec3 p = env.batch().state(0).segment<3>(0);
    last_gap = (env.target(0) - p).norm();
    EXPECT_DOUBLE_EQ(env.reward_terms_data()[5 * 2 + 0], -0.1 * last_gap);
    EXPECT_EQ(env.reward_terms_data()[4 * 2 + 0], 0.0);
  }
  // The circle moves at 1.8 m/s; a proportional chase lags it, but stays within half a metre.
  EXPECT_LT(last_gap, 0.5);
}

// The gate term pays its weight once per gate passed.
TEST(VecEnvReward, TheGateTermPaysPerGate) {
  auto env = make_env("racing", 1,
                      "{racing: {track: ../tracks/straight.yaml, laps: 1}, reward: {gate: 2.5}}");
  double paid = 0.0;
  int passed = 0;
  std::vector<double> act(3);
  for (int t = 0; t < 2000 && !env.done_data()[0]; ++t) {
    const Vec3 p = env.batch().state(0).segment<3>(0);
    const Gate& g = env.config().track.gates[static_cast<std::size_t>(env.next_gate_data()[0])];
    const Vec3 d = 0.5 * (g.center_m + 0.5 * g.normal() - p);
    for (int k = 0; k < 3; ++k) act[static_cast<std::size_t>(k)] = std::clamp(d[k], -1.0, 1.0);
    const int before = env.gates_passed_data()[0];
    env.step(act.data());
    paid += env.reward_terms_data()[4];
    passed += env.done_data()[0] ? env.finished_gates_data()[0] - before
                                 : env.gates_passed_data()[0] - before;
  }
  EXPECT_EQ(passed, 3);
  EXPECT_DOUBLE_EQ(paid, 2.5 * 3);
}

// The trajectory task reads its reference as experiment files do, so a minimum-snap plan is a
// task too: the target is the plan (started at the episode's start with no time offset).
// The shipped trajectory env file with its circle replaced by `reference` (overrides would merge
// the circle's keys in), parsed from its own path, every episode from the reference's start.
EnvFile trajectory_env_with(const std::string& reference) {
  const std::string path = test::source_path("config/rl/trajectory.yaml");
  std::string text = read_text_file(path, "env file");
  const std::string circle =
      "reference: {type: circle, center_m: [0, 0, 1.5], radius_m: 2.0, period_s: 7.0}";
  EXPECT_NE(text.find(circle), std::string::npos);
  text.replace(text.find(circle), circle.size(), reference);
  return parse_env_config(text, path, "{trajectory: {time_offset_max_s: 0}}");
}

// Over 10 control steps with zero actions, both envs' targets are `expected`'s positions.
void expect_targets_follow(VecEnv<double>& env, const Reference& expected) {
  env.reset(3);
  const std::vector<double> zero(static_cast<std::size_t>(2 * env.action_size()), 0.0);
  for (int k = 0; k < 10; ++k) {
    const double t = k * env.control_dt_s();
    for (int e = 0; e < 2; ++e)
      EXPECT_EQ(env.target(e), expected.at(t).position_m) << "env " << e << " t = " << t;
    env.step(zero.data());
  }
}

TEST(VecEnvTasks, TheTrajectoryTaskFollowsAMinimumSnapPlan) {
  const EnvFile f = trajectory_env_with(
      "reference: {type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1.5]}, "
      "{time_s: 2, position_m: [2, 1, 1.5], yaw_rad: 0.5}, "
      "{time_s: 4, position_m: [0, 2, 2]}]}");
  VecEnv<double> env(f.model, f.config, 2, 1);
  std::vector<planning::Waypoint> w(3);
  w[0].position_m = Vec3(0, 0, 1.5);
  w[1].position_m = Vec3(2, 1, 1.5);
  w[1].yaw_rad = 0.5;
  w[2].position_m = Vec3(0, 2, 2);
  expect_targets_follow(env, TrajectoryReference(planning::plan_min_snap(w, {2.0, 2.0})));
}

TEST(VecEnvTasks, TheTrajectoryTaskFollowsAMinimumSnapPlanThroughATracksGates) {
  // reference: {type: min_snap, track: ...}: the track path resolves against the env file's
  // folder, and the target is the plan through the start and the gate centres.
  const EnvFile f = trajectory_env_with(
      "reference: {type: min_snap, track: ../tracks/circuit.yaml, time_weight: 300}");
  VecEnv<double> env(f.model, f.config, 2, 1);
  const Track track = load_track(test::source_path("config/tracks/circuit.yaml"));
  std::vector<planning::Waypoint> w{{track.start_position_m, track.start_yaw_rad, {}, {}}};
  for (const Gate& g : track.gates)
    w.push_back({g.center_m, std::atan2(g.normal().y(), g.normal().x()), {}, {}});
  planning::TimeAllocationOptions unwrapped;
  unwrapped.min_snap.unwrap_yaw = true;
  const TrajectoryReference expected(planning::plan_min_snap(
      w, planning::allocate_segment_times(w, 300.0, unwrapped), unwrapped.min_snap));
  EXPECT_EQ(expected.at(0.0).position_m, track.start_position_m);
  expect_targets_follow(env, expected);
}

}  // namespace
}  // namespace dronetwin::rl
