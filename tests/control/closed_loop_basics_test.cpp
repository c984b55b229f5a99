// ClosedLoop mechanics: the controller runs every f_physics / f_control steps (thesis Eq. 3.11)
// with a zero-order hold in between, sees the measured state, and its failures are reported.

#include <gtest/gtest.h>

#include <type_traits>
#include <vector>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

// Records when it is called and what it saw; commands hover thrust.
class Recorder : public ControllerBase {
 public:
  using ControllerBase::ControllerBase;
  std::string_view name() const override { return "recorder"; }
  std::unique_ptr<ControllerBase> clone() const override {
    return std::make_unique<Recorder>(*this);
  }
  std::vector<double> times;
  std::vector<StateVector> seen;
  bool poison = false;

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override {
    times.push_back(in.time_s);
    seen.push_back(in.state);
    if (poison) return GeneralizedForce(NAN, 0, 0, 0);
    return GeneralizedForce(model().mass_kg() * 9.81, 0, 0, 0);
  }
};

// A temporary reference would dangle once the constructor returns: it does not compile.
static_assert(
    !std::is_constructible_v<ClosedLoop, Simulator&, ControllerBase&, SetpointReference, double>);
static_assert(std::is_constructible_v<ClosedLoop, Simulator&, ControllerBase&,
                                      const SetpointReference&, double>);

TEST(ClosedLoop, RunsTheControllerAtItsRateWithAZeroOrderHold) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  cfg.disturbances.ground_effect = false;  // hover trim without ground effect is exact
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 100.0);
  EXPECT_EQ(loop.steps_per_control(), 10);
  ASSERT_TRUE(loop.run(1.0).ok());
  // Every 10th step from t = 0, and at t = 1 s: run() leaves the loop updated at its last instant
  // (a log row there shows the command in effect from then on; a next run() continues it).
  ASSERT_EQ(ctrl.times.size(), 101u);
  for (std::size_t k = 0; k < ctrl.times.size(); ++k)
    EXPECT_NEAR(ctrl.times[k], 0.01 * static_cast<double>(k), 1e-12);
  // Hover thrust through the exact allocation keeps the vehicle at 1 m.
  EXPECT_NEAR(sim.state()[2], 1.0, 1e-9);
}

TEST(ClosedLoop, ControllerSeesTheMeasuredState) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  cfg.noise.enabled = true;
  cfg.seed = 3;
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 1000.0);
  loop.run(0.05);
  // The last call (at t = 0.05 s, after the last step) saw the measured state then: replay it.
  Simulator replay(model, cfg);
  replay.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl2(model);
  ClosedLoop loop2(replay, ctrl2, ref, 1000.0);
  loop2.run(0.049);
  loop2.step();
  EXPECT_EQ(ctrl.seen.size(), 51u);
  EXPECT_EQ(ctrl.seen.back(), replay.measured_state());
  EXPECT_NE(ctrl.seen.back(), replay.state());
}

TEST(ClosedLoop, RejectsRatesThatDoNotDivideThePhysicsRate) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  Recorder ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  EXPECT_THROW(ClosedLoop(sim, ctrl, ref, 300.0), InvalidArgument);
  EXPECT_THROW(ClosedLoop(sim, ctrl, ref, 2000.0), InvalidArgument);
  EXPECT_THROW(ClosedLoop(sim, ctrl, ref, 0.0), InvalidArgument);
}

TEST(ClosedLoop, NonFiniteControllerOutputIsReportedNotFlown) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  ctrl.poison = true;
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 100.0);
  try {
    loop.step();
    FAIL() << "expected SimulationError";
  } catch (const SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("recorder"), std::string::npos);
  }
  EXPECT_TRUE(sim.state().allFinite());
}

TEST(ClosedLoop, RunEndsWithControllerFailedAndShowsTheObserverEveryInstant) {
  // A controller that turns NaN at t = 20 ms: run() stops there with its own status, keeps the
  // good steps, and the observer saw t = 0 .. 19 ms, then finish() with the status.
  class FailsLater : public Recorder {
   public:
    using Recorder::Recorder;

   protected:
    GeneralizedForce do_calculate_u(const ControlInput& in) override {
      poison = in.time_s >= 0.02 - 1e-12;
      return Recorder::do_calculate_u(in);
    }
  };
  struct Watch : LoopObserver {
    std::vector<double> t;
    StepResult end;
    int finished = 0;
    void observe(const ClosedLoop& l) override { t.push_back(l.simulator().time_s()); }
    void finish(const ClosedLoop&, const StepResult& r) override {
      end = r;
      ++finished;
    }
  };
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  FailsLater ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 1000.0);
  Watch watch;
  const StepResult r = loop.run(1.0, &watch);
  EXPECT_EQ(r.status, StepStatus::kControllerFailed);
  EXPECT_EQ(r.steps_taken, 20);
  EXPECT_EQ(sim.step_count(), 20);
  EXPECT_TRUE(sim.status() == StepStatus::kOk);  // the simulator itself did not fail
  EXPECT_NE(loop.failure_message().find("recorder"), std::string::npos) << loop.failure_message();
  ASSERT_EQ(watch.t.size(), 20u);
  EXPECT_NEAR(watch.t.back(), 0.019, 1e-12);
  EXPECT_EQ(watch.finished, 1);
  EXPECT_EQ(watch.end.status, StepStatus::kControllerFailed);
}

TEST(ClosedLoop, ANonFiniteReferenceEndsTheRunWithAStatus) {
  class Breaks : public Reference {
   public:
    ReferencePoint at(double t_s) const override {
      ReferencePoint p;
      p.position_m = Vec3(0, 0, t_s < 0.005 ? 1.0 : NAN);
      return p;
    }
    std::unique_ptr<Reference> clone() const override { return std::make_unique<Breaks>(); }
    std::string describe() const override { return "breaks"; }
  };
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  Breaks ref;
  ClosedLoop loop(sim, ctrl, ref, 1000.0);
  const StepResult r = loop.run(1.0);
  EXPECT_EQ(r.status, StepStatus::kControllerFailed);
  EXPECT_EQ(r.steps_taken, 5);
  EXPECT_NE(loop.failure_message().find("reference at t = 0.005"), std::string::npos)
      << loop.failure_message();
}

TEST(ClosedLoop, RealTimePacingReachesAboutOne) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 100.0);
  loop.set_real_time(true);
  loop.run(0.2);
  // Sleeping can only slow the loop down: it never runs faster than real time.
  EXPECT_LE(loop.achieved_real_time_factor(), 1.0 + 1e-3);
  EXPECT_GT(loop.achieved_real_time_factor(), 0.0);
}

TEST(ClosedLoop, UpdateIsIdempotentAndStepRunsItOnlyWhenDue) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  cfg.disturbances.ground_effect = false;
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 250.0);  // every 4 steps
  ASSERT_EQ(loop.steps_per_control(), 4);
  EXPECT_EQ(loop.control_updates(), 0);
  EXPECT_TRUE(loop.update());  // step 0 is a control instant
  EXPECT_FALSE(loop.update());
  EXPECT_FALSE(loop.update());
  EXPECT_EQ(ctrl.times.size(), 1u);
  // The command is applied at once (the rotor reference), and held.
  EXPECT_EQ(sim.rotor_speed_reference_rad_s(), loop.last_rotor_command());
  EXPECT_NEAR(loop.last_command()[0], model->mass_kg() * 9.81, 1e-9);
  ASSERT_TRUE(loop.step().ok());  // update() inside is a no-op: already ran at step 0
  EXPECT_EQ(ctrl.times.size(), 1u);
  for (int k = 1; k < 4; ++k) {
    EXPECT_FALSE(loop.update()) << "step " << k << " is not a control instant";
    ASSERT_TRUE(loop.step().ok());
  }
  EXPECT_EQ(ctrl.times.size(), 1u);
  EXPECT_EQ(sim.step_count(), 4);
  EXPECT_TRUE(loop.update());
  EXPECT_FALSE(loop.update());
  ASSERT_TRUE(loop.step().ok());
  ASSERT_EQ(ctrl.times.size(), 2u);
  EXPECT_NEAR(ctrl.times[1], 0.004, 1e-15);
  EXPECT_EQ(loop.control_updates(), 2);

  // Calling update() before every step (as the experiment runner does) changes nothing: the same
  // controller calls at the same instants and the same trajectory as step() alone.
  Simulator a(model, cfg), b(model, cfg);
  a.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  b.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ca(model), cb(model);
  const SetpointReference up(Vec3(0, 0, 1.2));
  ClosedLoop la(a, ca, up, 100.0), lb(b, cb, up, 100.0);
  for (int k = 0; k < 250; ++k) {
    la.update();
    la.update();
    ASSERT_TRUE(la.step().ok());
    ASSERT_TRUE(lb.step().ok());
  }
  EXPECT_EQ(ca.times, cb.times);
  EXPECT_EQ(ca.times.size(), 25u);
  EXPECT_EQ(a.state(), b.state());
}

TEST(ClosedLoop, AControllerThatThrewRunsAgainOnTheNextUpdate) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Recorder ctrl(model);
  ctrl.poison = true;
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 1000.0);
  EXPECT_THROW(loop.update(), SimulationError);
  EXPECT_EQ(loop.control_updates(), 0);
  ctrl.poison = false;
  EXPECT_TRUE(loop.update());  // not marked as done by the failed attempt
  EXPECT_EQ(loop.control_updates(), 1);
  EXPECT_EQ(sim.step_count(), 0);
}

TEST(ClosedLoop, RotorSpeedControllersReportTheForceOfTheirCommand) {
  // A controller that commands rotor speeds directly: last_command() is what those speeds
  // produce through the thrust polynomials and the allocation matrix.
  class Speeds : public ControllerBase {
   public:
    using ControllerBase::ControllerBase;
    std::string_view name() const override { return "speeds"; }
    ControlLevel level() const override { return ControlLevel::kRotorSpeed; }
    std::unique_ptr<ControllerBase> clone() const override {
      return std::make_unique<Speeds>(*this);
    }

   protected:
    RotorVector do_calculate_actuator_cmd(const ControlInput&) override {
      return model().hover_speeds_rad_s();
    }
  };
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  Speeds ctrl(model);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, ctrl, ref, 1000.0);
  ASSERT_TRUE(loop.step().ok());
  EXPECT_NEAR(loop.last_command()[0], model->mass_kg() * 9.81, 1e-9);
  EXPECT_NEAR(loop.last_command().tail<3>().norm(), 0.0, 1e-9);
  EXPECT_EQ(loop.saturated_updates(), 0);
}

}  // namespace
}  // namespace dronetwin
