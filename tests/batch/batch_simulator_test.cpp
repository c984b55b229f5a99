// BatchSimulator against the Simulator it batches: every lane in double equals a Simulator flying
// the same vehicle (all 64 disturbance-switch combinations, three airframes, per-lane parameters,
// ground contact), results do not depend on threads or batch size, failed lanes stop alone.

#include "dronetwin/batch/batch_simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;

template <class F>
void expect_error(F&& f, const std::string& part) {
  const std::string e = test::error_of(f);
  EXPECT_NE(e.find(part), std::string::npos) << "error: " << e << "\nexpected to contain: " << part;
}

/// A lane's flight: a start state, piecewise-constant rotor references (changed every 0.5 s),
/// wind, and per-lane parameter edits.
struct LaneFlight {
  StateVector start;
  RotorVector start_speeds;
  std::vector<RotorVector> references;
  Vec3 wind = Vec3::Zero();
  std::vector<std::pair<ModelParameter, double>> edits;
};

LaneFlight random_flight(const VehicleModel& model, Random& rng, int lane) {
  LaneFlight f;
  f.start = Simulator::hover_state(
      Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, lane % 3 == 0 ? 0.0 : 0.3 + rng.uniform()),
      rng.uniform() * 6.0);
  // Some lanes start tilted and turning.
  if (lane % 3 == 2) {
    f.start.segment<4>(state_index::kQuaternion) += 0.1 * Vec4(0, rng.normal(), rng.normal(), 0);
    f.start.segment<3>(state_index::kAngularVelocity) = Vec3(rng.normal(), rng.normal(), 0.5);
    f.start.segment<3>(state_index::kVelocity) = Vec3(rng.normal(), rng.normal(), rng.normal());
  }
  const RotorVector hover = model.hover_speeds_rad_s();
  f.start_speeds = hover * (lane % 3 == 0 ? 0.0 : 1.0);
  for (int k = 0; k < 20; ++k) {
    RotorVector r = hover;
    for (Eigen::Index i = 0; i < r.size(); ++i) r[i] *= 1.0 + 0.02 * rng.normal() + 0.01 * (k % 2);
    f.references.push_back(r);
  }
  f.wind = Vec3(2.0 * rng.normal(), 2.0 * rng.normal(), 0.3 * rng.normal());
  if (lane % 2 == 1) {
    f.edits = {
        {ModelParameter::kMass, model.mass_kg() * (0.9 + 0.2 * rng.uniform())},
        {ModelParameter::kInertiaZZ, model.inertia_kgm2()(2, 2) * (1.0 - 0.1 * rng.uniform())},
        {ModelParameter::kThrustK1,
         parameter_value(model.parameters(), ModelParameter::kThrustK1) * 1.03},
        {ModelParameter::kRotorDrag,
         1e-5 + 2.0 * parameter_value(model.parameters(), ModelParameter::kRotorDrag)},
        {ModelParameter::kTauRise, 0.02 + 0.02 * rng.uniform()},
        {ModelParameter::kBodyDragX, 0.05 + 0.1 * rng.uniform()}};
  }
  return f;
}

/// The Simulator flying lane `f` for `steps` steps, or until a step fails.
struct SimRun {
  StateVector state;
  RotorVector speeds;
  StepStatus status = StepStatus::kOk;
  std::int64_t steps = 0;
  ContactState contact;
};

SimRun fly_simulator(const VehicleModel& model, const SimConfig& cfg, const LaneFlight& f,
                     int steps) {
  VehicleSpec spec = model.spec();
  for (const auto& [p, v] : f.edits) set_parameter_value(spec, p, v);
  SimConfig c = cfg;
  c.environment.wind_W_m_s = f.wind;
  Simulator sim(std::make_shared<const VehicleModel>(spec), c);
  sim.reset(f.start, f.start_speeds);
  SimRun run;
  for (int k = 0; k < steps; ++k) {
    if (k % 500 == 0)
      sim.set_rotor_speed_reference(f.references[static_cast<std::size_t>(k / 500) % 20]);
    const StepResult r = sim.step();
    if (!r.ok()) {
      run.status = r.status;
      break;
    }
    ++run.steps;
  }
  run.state = sim.state();
  run.speeds = sim.data().rotor_speed_rad_s;
  run.contact = sim.data().contact;
  return run;
}

template <class T>
void start_lanes(BatchSimulator<T>& batch, const std::vector<LaneFlight>& flights) {
  for (int l = 0; l < batch.size(); ++l) {
    const LaneFlight& f = flights[static_cast<std::size_t>(l)];
    for (const auto& [p, v] : f.edits) batch.set_parameter(p, l, v);
    batch.set_wind(l, f.wind);
    batch.reset(l, f.start, f.start_speeds);
  }
}

template <class T>
void fly_batch(BatchSimulator<T>& batch, const std::vector<LaneFlight>& flights, int steps) {
  for (int k = 0; k < steps; k += 500) {
    for (int l = 0; l < batch.size(); ++l) {
      if (batch.status(l) != StepStatus::kOk) continue;
      batch.set_rotor_speed_reference(
          l,
          flights[static_cast<std::size_t>(l)].references[static_cast<std::size_t>(k / 500) % 20]);
    }
    batch.step(std::min(500, steps - k));
  }
}

double relative_gap(const StateVector& a, const StateVector& b) {
  double worst = 0.0;
  for (int i = 0; i < kStateSize; ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / (1.0 + std::abs(b[i])));
  return worst;
}

// Every lane of a double batch equals the Simulator over 10 s, for every combination of the six
// disturbance switches and three airframes (one with tilted rotors), with per-lane parameters,
// wind, ground contact (lanes start on the ground) and lanes that may tumble and fail.
TEST(BatchSimulator, EveryLaneEqualsTheSimulatorForAllSwitchCombinationsAndAirframes) {
  // 10 s at 1 kHz; 2.5 s under a sanitizer (lanes start on the ground, so contact is still used).
  constexpr int kSteps = test::full_or_sanitized(10000, 2500);
  constexpr int kLanesPerCase = 3;
  int lanes_checked = 0, lanes_touching = 0, lanes_failed = 0;
  double worst = 0.0;
  for (const char* name : {"qdrone2", "hexarotor", "tilted_hexarotor"}) {
    const auto model = test::load_model(name);
    for (int mask = 0; mask < 64; ++mask) {
      SimConfig cfg;
      cfg.disturbances = DisturbanceSwitches::none();
      cfg.disturbances.rotor_drag = (mask & 1) != 0;
      cfg.disturbances.rolling_moment = (mask & 2) != 0;
      cfg.disturbances.drag_moment = (mask & 4) != 0;
      cfg.disturbances.ground_effect = (mask & 8) != 0;
      cfg.disturbances.gyroscopic = (mask & 16) != 0;
      cfg.disturbances.body_drag = (mask & 32) != 0;
      Random rng(static_cast<std::uint64_t>(1000 * mask + 7));
      std::vector<LaneFlight> flights;
      for (int l = 0; l < kLanesPerCase; ++l)
        flights.push_back(random_flight(*model, rng, l + mask));
      BatchSimulator<double> batch(model, cfg, kLanesPerCase);
      start_lanes(batch, flights);
      fly_batch(batch, flights, kSteps);
      for (int l = 0; l < kLanesPerCase; ++l) {
        const SimRun sim = fly_simulator(*model, cfg, flights[static_cast<std::size_t>(l)], kSteps);
        SCOPED_TRACE(std::string(name) + " switches " + std::to_string(mask) + " lane " +
                     std::to_string(l));
        ASSERT_EQ(batch.status(l), sim.status);
        ASSERT_EQ(batch.step_count(l), sim.steps);
        const double gap = relative_gap(batch.state(l), sim.state);
        worst = std::max(worst, gap);
        ASSERT_LE(gap, 1e-12) << batch.state(l).transpose() << "\n" << sim.state.transpose();
        ASSERT_LE((batch.rotor_speeds(l) - sim.speeds).cwiseAbs().maxCoeff(), 1e-9);
        EXPECT_EQ(batch.contact(l).in_contact, sim.contact.in_contact);
        EXPECT_EQ(batch.contact(l).crashed, sim.contact.crashed);
        EXPECT_EQ(batch.contact(l).touchdowns, sim.contact.touchdowns);
        ++lanes_checked;
        lanes_touching += sim.contact.touchdowns > 0 || sim.contact.in_contact;
        lanes_failed += sim.status != StepStatus::kOk;
      }
    }
  }
  EXPECT_EQ(lanes_checked, 3 * 64 * kLanesPerCase);
  // The flights exercise the contact path: lanes that start on the ground or come down.
  EXPECT_GT(lanes_touching, 50);
  std::printf("[ batch    ] %d lanes, %d touched the ground, %d failed; worst relative gap %.3g\n",
              lanes_checked, lanes_touching, lanes_failed, worst);
}

// a * b + c compiled for a CPU with FMA instructions, where GCC would fuse it unless told not to.
#if defined(__x86_64__)
[[gnu::target("fma"), gnu::noinline]] double multiply_add(double a, double b, double c) {
  return a * b + c;
}
#else  // other targets with FMA (aarch64) have it without asking
[[gnu::noinline]] double multiply_add(double a, double b, double c) { return a * b + c; }
#endif

// The equality above holds in a native build only because the build turns FMA contraction off
// (CMakeLists.txt; docs/batch.md). The portable build has no FMA to show it, so this checks the
// flag directly: with a = 1 + 2^-30, b = 1 - 2^-30, the product 1 - 2^-60 rounds to 1 and
// a * b - 1 is 0, where one fused instruction gives -2^-60.
TEST(BatchSimulator, TheBuildFusesNoMultiplyAddThatTheSourceDoesNotAskFor) {
#if defined(__x86_64__)
  if (!__builtin_cpu_supports("fma")) GTEST_SKIP() << "this CPU has no FMA instructions";
#endif
  const volatile double a = 1.0 + 0x1p-30, b = 1.0 - 0x1p-30, c = -1.0;
  EXPECT_EQ(std::fma(a, b, c), -0x1p-60);  // what fusing would give
  EXPECT_EQ(multiply_add(a, b, c), 0.0);
}

/// A batch of `n` lanes flying the first `n` of a fixed set of flights, stepped by `threads`.
std::vector<double> fly_and_collect(int n, int threads, const std::vector<LaneFlight>& flights,
                                    const std::shared_ptr<const VehicleModel>& model) {
  SimConfig cfg;
  cfg.environment.wind_W_m_s = Vec3(1.0, 0.0, 0.0);
  BatchSimulator<double> batch(model, cfg, n, threads);
  start_lanes(batch, flights);
  fly_batch(batch, flights, 3000);
  std::vector<double> out;
  for (int l = 0; l < n; ++l) {
    const StateVector x = batch.state(l);
    out.insert(out.end(), x.data(), x.data() + kStateSize);
    out.push_back(static_cast<double>(batch.step_count(l)));
    out.push_back(static_cast<double>(batch.status(l)));
  }
  return out;
}

// Bitwise the same lanes whatever the number of threads and the batch size (1, 7, 1024; 256 under
// a sanitizer): a lane
// depends only on its own inputs.
TEST(BatchSimulator, ResultsAreBitwiseIndependentOfThreadsAndBatchSize) {
  const auto model = test::load_model("qdrone2");
  Random rng(99);
  std::vector<LaneFlight> flights;
  constexpr int kLanesUsed = test::full_or_sanitized(1024, 256);
  for (int l = 0; l < kLanesUsed; ++l) flights.push_back(random_flight(*model, rng, l));
  const std::vector<double> one_thread = fly_and_collect(kLanesUsed, 1, flights, model);
  const std::vector<double> two_threads = fly_and_collect(kLanesUsed, 2, flights, model);
  ASSERT_EQ(one_thread.size(), two_threads.size());
  EXPECT_EQ(std::memcmp(one_thread.data(), two_threads.data(), one_thread.size() * sizeof(double)),
            0);
  for (int n : {1, 7}) {
    const std::vector<double> small = fly_and_collect(n, 2, flights, model);
    EXPECT_EQ(std::memcmp(small.data(), one_thread.data(), small.size() * sizeof(double)), 0)
        << "batch of " << n;
  }
}

// The rows of one pack lie in different L1 sets (address bits 6-11) whatever the lane count,
// powers of two included: the stride is an odd number of 64-byte lines, at most two lines longer
// than the lanes need, and what is written in the padding (lanes past size()) fails no lane.
template <class T>
void expect_rows_in_distinct_sets(const std::shared_ptr<const VehicleModel>& model, int n) {
  SCOPED_TRACE(::testing::Message() << n << " lanes of " << sizeof(T) << "-byte values");
  BatchSimulator<T> batch(model, SimConfig(), n, 1);
  const int stride = batch.stride();
  const auto row_bytes = static_cast<std::size_t>(stride) * sizeof(T);
  EXPECT_GE(stride, n);
  EXPECT_EQ(stride % BatchSimulator<T>::kLanes, 0);
  EXPECT_EQ(row_bytes % 64, 0u);
  EXPECT_LT(row_bytes - static_cast<std::size_t>(n) * sizeof(T), 2u * 64u);
  std::vector<std::size_t> sets;
  for (int k = 0; k < kStateSize; ++k) {
    const auto address = reinterpret_cast<std::uintptr_t>(batch.state_data() + k * stride);
    sets.push_back((address / 64) % 64);
  }
  std::sort(sets.begin(), sets.end());
  EXPECT_EQ(std::adjacent_find(sets.begin(), sets.end()), sets.end())
      << "two of the 13 state rows share an L1 set";
  // A NaN in the padding is not a lane's state.
  const int pad = stride - 1;
  if (pad >= n) {
    batch.state_data()[static_cast<std::size_t>(kPosition) * stride + pad] =
        std::numeric_limits<T>::quiet_NaN();
    EXPECT_EQ(batch.step(3), 0) << "a lane failed on the padding's NaN";
  }
}

TEST(BatchSimulator, RowsOfAPackFallInDifferentCacheSets) {
  const auto model = test::load_model("qdrone2");
  for (int n : {1, 7, 512, 1000, 1024, 4096}) {
    expect_rows_in_distinct_sets<double>(model, n);
    expect_rows_in_distinct_sets<float>(model, n);
  }
}

// A lane whose state is made invalid through the arrays stops with a status; its neighbours in the
// same pack fly on exactly as they would have; reset() revives it.
TEST(BatchSimulator, AFailedLaneStopsAloneAndResetRevivesIt) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  const int n = 2 * BatchSimulator<double>::kLanes;
  BatchSimulator<double> batch(model, cfg, n);
  BatchSimulator<double> reference(model, cfg, n);
  for (int l = 0; l < n; ++l) {
    for (auto* b : {&batch, &reference}) {
      b->reset(l, Simulator::hover_state(Vec3(0, 0, 1.0 + 0.01 * l)), model->hover_speeds_rad_s());
    }
  }
  const int bad = 2, bad_input = 3, diverging = 5;
  batch.state_data()[static_cast<std::size_t>(kPosition) * batch.stride() + bad] =
      std::numeric_limits<double>::quiet_NaN();
  batch.rotor_speed_reference_data()[bad_input] = std::numeric_limits<double>::infinity();
  // Beyond the 1e5 m position limit within the first step.
  for (auto* b : {&batch, &reference}) {
    b->state_data()[static_cast<std::size_t>(kPosition) * b->stride() + diverging] = 99999.9;
    b->state_data()[static_cast<std::size_t>(state_index::kVelocity) * b->stride() + diverging] =
        200.0;
  }
  const int failed = batch.step(200);
  reference.step(200);
  EXPECT_EQ(failed, 3);
  EXPECT_EQ(batch.status(bad), StepStatus::kInvalidState);
  EXPECT_EQ(batch.status(bad_input), StepStatus::kInvalidInput);
  EXPECT_EQ(batch.status(diverging), StepStatus::kDiverged);
  EXPECT_EQ(batch.step_count(bad), 0);
  EXPECT_LT(batch.step_count(diverging), 200);
  EXPECT_TRUE(batch.state(diverging).allFinite());  // the last good state is kept
  for (int l = 0; l < n; ++l) {
    if (l == bad || l == bad_input || l == diverging) continue;
    EXPECT_EQ(batch.status(l), StepStatus::kOk);
    EXPECT_EQ(batch.step_count(l), 200);
    EXPECT_EQ(batch.state(l), reference.state(l)) << "lane " << l;
  }
  batch.reset(bad, Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  EXPECT_EQ(batch.status(bad), StepStatus::kOk);
  EXPECT_EQ(batch.step(10), 2);
  EXPECT_EQ(batch.step_count(bad), 10);
}

// Parameters change only their lane, and a lane set back to the nominal value is the nominal
// vehicle again, bit for bit.
TEST(BatchSimulator, PerLaneParametersChangeOnlyTheirLane) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, SimConfig{}, 3);
  for (int l = 0; l < 3; ++l)
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  batch.set_parameter(ModelParameter::kMass, 1, 1.2 * model->mass_kg());
  batch.set_parameter(ModelParameter::kMass, 2, 1.2 * model->mass_kg());
  batch.set_parameter(ModelParameter::kMass, 2, model->mass_kg());
  batch.step(500);
  // Lane 1 is heavier: at the same rotor speeds it sinks; a free fall for the extra weight.
  const double dz = batch.state(1)[kPosition + 2] - batch.state(0)[kPosition + 2];
  const double a = 9.81 * (1.0 - 1.0 / 1.2);  // the missing acceleration, roughly
  EXPECT_LT(dz, -0.5 * 0.5 * a * 0.25 * 0.5);
  EXPECT_EQ(batch.state(2), batch.state(0));
  EXPECT_DOUBLE_EQ(batch.parameter(ModelParameter::kMass, 1), 1.2 * model->mass_kg());
}

TEST(BatchSimulator, BadInputsAreNamed) {
  const auto model = test::load_model("qdrone2");
  SimConfig noisy;
  noisy.noise.enabled = true;
  noisy.noise.parameters.theta[0].a = 5.0;  // an unstable OU block, as validate() names it
  expect_error([&] { BatchSimulator<double>(model, noisy, 4); }, "noise.theta");
  expect_error([&] { BatchSimulator<double>(model, SimConfig{}, 0); }, "num_vehicles");
  expect_error([&] { BatchSimulator<double>(model, SimConfig{}, 4, 0); }, "num_threads");
  BatchSimulator<double> batch(model, SimConfig{}, 4);
  expect_error([&] { batch.reset(4, StateVector::Zero()); }, "lane 4");
  expect_error([&] { batch.reset(0, StateVector::Zero()); }, "quaternion");
  expect_error([&] { batch.set_parameter(ModelParameter::kMass, 1, -1.0); }, "mass[lane 1]");
  expect_error([&] { batch.set_parameter(ModelParameter::kTauRise, 0, std::nan("")); }, "finite");
  expect_error([&] { batch.set_rotor_speed_reference(0, RotorVector::Zero(3)); },
               "expected 4 values");
  expect_error([&] { batch.step(-1); }, "n >= 0");
  expect_error([&] { batch.set_wind(2, Vec3(0, std::nan(""), 0)); }, "set_wind: lane 2");
  expect_error([&] { batch.set_generalized_force(1, Vec4(std::nan(""), 0, 0, 0)); },
               "lane 1: [T, tau_x, tau_y, tau_z][0]");
  expect_error([&] { batch.reset(3, Simulator::hover_state(Vec3(0, 0, -0.5))); },
               "lane 3: state[2]: z = -0.5 m is below the ground");
  expect_error([&] { batch.reset(0, Simulator::hover_state(Vec3(0, 0, 1)), RotorVector::Zero(6)); },
               "rotor speeds: expected 4 values, got 6");
}

// Float lanes follow the double ones. Single precision rounds at 6e-8 relative; over 10 s of
// hover (1e4 steps) the accumulated error stays below 1e4 * 6e-8 * 2 m = 1.2 mm (linear growth,
// the worst case for a marginally stable hover), and over 1 s of the random flights above below
// 1e3 * 6e-8 * (1 + |p|) per metre of position. Measured: docs/batch.md.
TEST(BatchSimulator, FloatLanesTrackTheDoubleOnesWithinSinglePrecision) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  {
    BatchSimulator<double> d(model, cfg, 1);
    BatchSimulator<float> f(model, cfg, 1);
    d.reset(0, Simulator::hover_state(Vec3(0, 0, 2.0)), model->hover_speeds_rad_s());
    f.reset(0, Simulator::hover_state(Vec3(0, 0, 2.0)), model->hover_speeds_rad_s());
    d.step(10000);
    f.step(10000);
    ASSERT_EQ(f.status(0), StepStatus::kOk);
    const double gap = (f.state(0) - d.state(0)).segment<3>(kPosition).norm();
    std::printf("[ batch    ] float vs double, 10 s hover: position gap %.3g m\n", gap);
    EXPECT_LT(gap, 1e4 * 6e-8 * 2.0);
  }
  Random rng(5);
  std::vector<LaneFlight> flights;
  for (int l = 0; l < 64; ++l) flights.push_back(random_flight(*model, rng, 3 * l + 1));
  BatchSimulator<double> d(model, cfg, 64);
  BatchSimulator<float> f(model, cfg, 64);
  start_lanes(d, flights);
  start_lanes(f, flights);
  fly_batch(d, flights, 1000);
  fly_batch(f, flights, 1000);
  double worst = 0.0;
  for (int l = 0; l < 64; ++l) {
    ASSERT_EQ(f.status(l), d.status(l));
    for (int k = 0; k < 3; ++k) {
      const double p = d.state(l)[kPosition + k];
      const double gap = std::abs(f.state(l)[kPosition + k] - p) / (1.0 + std::abs(p));
      worst = std::max(worst, gap);
    }
  }
  std::printf("[ batch    ] float vs double, 64 random 1 s flights: worst position gap %.3g\n",
              worst);
  EXPECT_LT(worst, 1e3 * 6e-8);
}

}  // namespace
}  // namespace dronetwin
