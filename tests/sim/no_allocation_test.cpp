// "No heap allocation inside a step": this test binary replaces the global operator new with a
// counting one, and a stepping loop (noise on, every term, motor lag) must not move the counter.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

#include "control/aggressive_lap.hpp"
#include "dronetwin/batch/batch_body_rate.hpp"
#include "dronetwin/batch/batch_pid.hpp"
#include "dronetwin/batch/batch_se3.hpp"
#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/policy/mlp.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"
#include "vehicle_link.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

// These are replacement allocation functions, so pairing them with malloc/free is correct; GCC's
// -Wmismatched-new-delete cannot tell them from ordinary calls.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

namespace dronetwin {
namespace {

TEST(NoAllocation, SteppingDoesNotAllocate) {
  SimConfig cfg;
  cfg.noise.enabled = true;
  cfg.environment.wind_W_m_s << 1.0, 0.0, 0.0;
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 0.2)), model->hover_speeds_rad_s());
  RotorVector ref = model->hover_speeds_rad_s();
  const long before = g_allocations.load();
  for (int k = 0; k < 2000; ++k) {
    ref[k % 4] += (k % 2 ? 1.0 : -1.0);
    sim.set_rotor_speed_reference(ref);
    sim.set_generalized_force(Vec4(15.0, 0.0, 0.0, 0.001));
    ASSERT_TRUE(sim.step().ok());
    volatile double sink = sim.measured_state()[2] + sim.measured_state_derivative()[5] +
                           sim.wrench_breakdown()[Term::kThrust].force_B.z();
    (void)sink;
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
}

// A wind field (shear, a gust, turbulence) and rotor faults that begin mid-run (a lost
// effectiveness swaps in a prebuilt kernel, a stuck motor records its speed).
TEST(NoAllocation, WindFieldFaultsAndBatteryDoNotAllocate) {
  SimConfig cfg;
  cfg.battery.enabled = true;
  cfg.environment.wind_W_m_s << 3.0, 0.0, 0.0;
  cfg.wind.shear.enabled = true;
  cfg.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
  cfg.wind.gusts[0] = {0.2, 0.5, Vec3(0.0, 2.0, 0.0)};
  cfg.wind.num_gusts = 1;
  cfg.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, 0, 0.5, 0.7};
  cfg.faults.rotor[1] = RotorFault{RotorFaultKind::kStuck, 1, 1.0, 1.0};
  cfg.faults.num_rotor_faults = 2;
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  const long before = g_allocations.load();
  const RotorVector full_throttle = RotorVector::Constant(model->num_rotors(), 3400.0);
  for (int k = 0; k < 1500; ++k) {
    // The last 300 steps at full throttle, where the pack caps the rotor speed.
    if (k == 1200) sim.set_rotor_speed_reference(full_throttle);
    ASSERT_TRUE(sim.step().ok()) << sim.failure_message();
    volatile double sink = sim.state_derivative()[5] + sim.wind_W_m_s().x() +
                           sim.wrench_breakdown()[Term::kThrust].force_B.z() +
                           sim.battery().voltage_V;
    (void)sink;
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_EQ(sim.data().active_faults, 3u);
  EXPECT_LT(sim.rotor_speeds_rad_s()[2], 3000.0);  // capped by the sagging pack
}

// A slung payload: the step integrates it with the vehicle (the payload's drag on), reads its
// tension and swing, and lets it go slack and jerk taut again (the rotors off, then on).
TEST(NoAllocation, SlungPayloadDoesNotAllocate) {
  SimConfig cfg;
  cfg.payload.enabled = true;
  cfg.payload.payload.drag_area_m2 = 0.01;
  cfg.payload.initial_swing1_rad = 0.3;
  cfg.environment.wind_W_m_s << 2.0, 0.0, 0.0;
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 3.0)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  const long before = g_allocations.load();
  for (int k = 0; k < 1500; ++k) {
    // 0.2 s of free fall: the cable goes slack; the rotors back on jerk it taut.
    if (k == 500) sim.set_rotor_speed_reference(RotorVector::Zero(model->num_rotors()));
    if (k == 700) sim.set_rotor_speed_reference(model->hover_speeds_rad_s() * 1.3);
    ASSERT_TRUE(sim.step().ok()) << sim.failure_message();
    volatile double sink = sim.state_derivative()[5] + sim.payload_tension_N() +
                           sim.swing_angles().gamma1_rad + sim.payload().position_W_m.z();
    (void)sink;
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(sim.payload().taut);
}

// The batch (issue: no allocation per step): stepping with two threads, parameters changed
// between steps (the packs are rebuilt in place), lanes failing and reset.
TEST(NoAllocation, BatchSteppingDoesNotAllocate) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, SimConfig{}, 100, 2);
  BatchSimulator<float> single(model, SimConfig{}, 100, 2);
  const StateVector hover = Simulator::hover_state(Vec3(0, 0, 1));
  RotorVector ref = model->hover_speeds_rad_s();
  for (int l = 0; l < 100; ++l) {
    batch.reset(l, hover, ref);
    single.reset(l, hover, ref);
  }
  const long before = g_allocations.load();
  for (int k = 0; k < 200; ++k) {
    batch.set_parameter(ModelParameter::kMass, k % 100, 1.5 + 0.001 * k);
    batch.set_rotor_speed_reference(k % 100, ref);
    batch.step(k % 3);
    single.step(5);
    if (k == 100) {
      batch.state_data()[k % 100] = 1e300;  // fails that lane
      batch.step(1);
      batch.reset(k % 100, hover, ref);
    }
  }
  EXPECT_EQ(g_allocations.load(), before);
}

// The cascaded PID and SE(3) with every feed-forward on a trajectory: the flat attitude and the
// drag's allocation are computed each update without allocating.
TEST(NoAllocation, ControllersWithFeedForwardDoNotAllocate) {
  const planning::Trajectory lap = test::aggressive_lap();
  const TrajectoryReference reference(lap);
  PidOptions pid_options;
  pid_options.acceleration_feed_forward = true;
  pid_options.angular_feed_forward = true;
  pid_options.drag_feed_forward = true;
  pid_options.max_tilt_rad = 0.6;
  CascadedPid pid(test::qdrone2(), PidGains::thesis_simulation(), pid_options, 1e-3);
  Se3Options se3_options;
  se3_options.gravity_compensation = true;
  se3_options.angular_feed_forward = true;
  se3_options.drag_feed_forward = true;
  Se3Controller se3(test::qdrone2(), Se3Gains::thesis(), se3_options);
  for (ControllerBase* controller :
       {static_cast<ControllerBase*>(&pid), static_cast<ControllerBase*>(&se3)}) {
    Simulator sim(test::qdrone2(), SimConfig{});
    sim.reset(Simulator::hover_state(lap.at(0.0).position_m),
              test::qdrone2()->hover_speeds_rad_s());
    ClosedLoop loop(sim, *controller, reference, 1000.0);
    ASSERT_TRUE(loop.step().ok());
    const long before = g_allocations.load();
    for (int k = 0; k < 500; ++k) ASSERT_TRUE(loop.step().ok());
    EXPECT_EQ(g_allocations.load() - before, 0) << controller->name();
  }
}

// Noise, the three batched inner loops and the batched allocation allocate nothing per step.
TEST(NoAllocation, BatchNoiseAndInnerLoopsDoNotAllocate) {
  const auto model = test::load_model("qdrone2");
  SimConfig noisy;
  noisy.noise.enabled = true;
  BatchSimulator<double> batch(model, noisy, 50, 2);
  BatchSe3Controller<double> se3(model, Se3Gains::thesis(), Se3Options{}, 50);
  PidOptions feed_forward;
  feed_forward.acceleration_feed_forward = true;
  feed_forward.angular_feed_forward = true;
  feed_forward.drag_feed_forward = true;
  BatchCascadedPid<double> pid(model, PidGains::thesis_simulation(), feed_forward, noisy.dt_s, 50);
  BatchBodyRateController<double> rates(model, BodyRateGains{}, 50);
  const StateVector hover = Simulator::hover_state(Vec3(0, 0, 1));
  for (int l = 0; l < 50; ++l) {
    batch.reset(l, hover, model->hover_speeds_rad_s());
    rates.set_command(l, model->mass_kg() * 9.81, Vec3::Zero());
  }
  std::vector<double> u(static_cast<std::size_t>(4 * batch.stride()), 0.0);
  const long before = g_allocations.load();
  for (int k = 0; k < 30; ++k) {
    batch.step(3, se3);
    batch.step(2, pid);
    batch.step(2, rates);
    batch.set_generalized_forces(u.data());
    batch.set_seed(k % 50, static_cast<std::uint64_t>(k));
  }
  EXPECT_EQ(g_allocations.load(), before);
}

// The batch in a wind field (a scalar pass per lane, turbulence per lane), new episodes' seeds.
TEST(NoAllocation, BatchWindFieldDoesNotAllocate) {
  const auto model = test::load_model("qdrone2");
  SimConfig windy;
  windy.environment.wind_W_m_s << 2.0, 1.0, 0.0;
  windy.wind.shear.enabled = true;
  windy.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kLight);
  BatchSimulator<double> batch(model, windy, 20, 2);
  for (int l = 0; l < 20; ++l)
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  const long before = g_allocations.load();
  for (int k = 0; k < 30; ++k) {
    batch.step(5);
    batch.set_seed(k % 20, static_cast<std::uint64_t>(k));
    volatile double sink = batch.air_velocity(k % 20).x();
    (void)sink;
  }
  EXPECT_EQ(g_allocations.load(), before);
}

// A policy evaluation (policy/mlp.hpp): the workspace is allocated once, by the evaluator's
// constructor; evaluating one observation or a batch of rows allocates nothing, in either
// precision. (The evaluator computes with plain loops over that workspace, no Eigen expression
// that could allocate through malloc, which this counter would not see.)
TEST(NoAllocation, PolicyEvaluationDoesNotAllocate) {
  Mlp m;
  const int widths[] = {64, 256, 256, 4};
  m.observation_mean = Eigen::VectorXd::Constant(widths[0], 0.1);
  m.observation_std = Eigen::VectorXd::Constant(widths[0], 2.0);
  for (int k = 0; k < 3; ++k) {
    Eigen::MatrixXd w(widths[k + 1], widths[k]);
    for (Eigen::Index i = 0; i < w.size(); ++i)
      w.data()[i] = 0.01 * static_cast<double>(i % 13) - 0.06;
    m.weights.push_back(w);
    m.biases.push_back(Eigen::VectorXd::Constant(widths[k + 1], 0.01));
  }
  m.action_scale = Eigen::VectorXd::Ones(widths[3]);
  for (const auto activation :
       {Mlp::Activation::kLeakyRelu, Mlp::Activation::kRelu, Mlp::Activation::kTanh}) {
    m.activation = activation;
    MlpEvaluator policy(std::make_shared<const Mlp>(m));
    std::vector<double> obs(static_cast<std::size_t>(8 * widths[0]), 0.5), action(8 * 4);
    std::vector<float> obs_f(obs.begin(), obs.end()), action_f(action.size());
    const long before = g_allocations.load();
    for (int k = 0; k < 20; ++k) {
      obs[static_cast<std::size_t>(k % 64)] += 0.01;
      policy.evaluate(obs.data(), action.data());
      policy.evaluate(obs_f.data(), action_f.data());
      policy.evaluate_rows(obs.data(), 8, action.data());
      policy.evaluate_rows(obs_f.data(), 8, action.data());
    }
    EXPECT_EQ(g_allocations.load(), before);
    EXPECT_TRUE(std::isfinite(action[0]));
  }
}

// The ROS bridge's simulator half (src/ros/vehicle_link.hpp) steps a period with every sensor
// type of hover_sensors.yaml sampling and delivering readings: no allocation either (the
// readings are fixed-size, collected into capacity reserved at construction).
TEST(NoAllocation, VehicleLinkPeriodsWithSensorsDoNotAllocate) {
  ros_bridge::VehicleLink link(
      {test::source_path("config/experiments/hover_sensors.yaml"), "", 100.0});
  const RotorVector hover = test::load_model("qdrone2")->hover_speeds_rad_s();
  ASSERT_EQ(link.command_rotor_speeds({hover.data(), hover.data() + hover.size()}), "");
  ASSERT_EQ(link.advance(), "");
  const long before = g_allocations.load();
  for (int period = 0; period < 50; ++period) ASSERT_TRUE(link.advance().empty());
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_FALSE(link.snapshot().sensor_readings.empty());  // they did deliver
}

}  // namespace
}  // namespace dronetwin
