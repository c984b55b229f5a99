// core/single_thread.hpp, and the simulator and closed loop that use it: a second thread calling
// an object in use gets a SimulationError naming the call, never a mixed state. Threads are
// synchronised by handshakes, not by sleeping, so the tests are deterministic.

#include "dronetwin/core/single_thread.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "dronetwin/control/closed_loop.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

TEST(SingleThreadGuard, ReentrantOnItsThreadRefusedOnAnother) {
  SingleThreadGuard guard;
  std::atomic<int> phase{0};
  std::string other_error;
  {
    const SingleThreadGuard::Hold outer(guard, "outer");
    const SingleThreadGuard::Hold inner(guard, "inner");  // same thread: fine
    std::thread t([&] {
      try {
        const SingleThreadGuard::Hold h(guard, "from the other thread");
      } catch (const SimulationError& e) {
        other_error = e.what();
      }
      try {
        guard.check("check");
      } catch (const SimulationError&) {
        phase = 1;
      }
    });
    t.join();
  }
  EXPECT_NE(other_error.find("from the other thread: this object is in use by another thread"),
            std::string::npos)
      << other_error;
  EXPECT_EQ(phase.load(), 1);
  // Released: another thread may take it now.
  bool taken = false;
  std::thread t2([&] {
    const SingleThreadGuard::Hold h(guard, "later");
    taken = true;
  });
  t2.join();
  EXPECT_TRUE(taken);
  const SingleThreadGuard copy = guard;  // a copy is a new, unused object
  (void)copy;
}

// A controller that, on its first call, lets the main thread act and waits until it has.
class Handshake : public ControllerBase {
 public:
  Handshake(std::shared_ptr<const VehicleModel> m, std::atomic<int>& phase)
      : ControllerBase(std::move(m)), phase_(&phase) {}
  std::string_view name() const override { return "handshake"; }
  std::unique_ptr<ControllerBase> clone() const override {
    return std::make_unique<Handshake>(*this);
  }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput&) override {
    if (phase_->load() == 0) {
      phase_->store(1);
      while (phase_->load() != 2) std::this_thread::yield();
    }
    return GeneralizedForce(model().mass_kg() * 9.81, 0, 0, 0);
  }

 private:
  std::atomic<int>* phase_;
};

TEST(SingleThreadGuard, ASimulatorFlownByOneThreadRefusesAnother) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  std::atomic<int> phase{0};
  Handshake controller(model, phase);
  SetpointReference ref(Vec3(0, 0, 1));
  ClosedLoop loop(sim, controller, ref, 1000.0);
  StepResult result;
  std::thread flyer([&] { result = loop.run(0.1); });
  while (phase.load() != 1) std::this_thread::yield();
  // The flyer is inside run(): every mutating call from here is refused, and nothing changes.
  const StateVector before = sim.state();
  std::string reset_error, step_error, steps_error, controller_error;
  try {
    sim.reset(Simulator::hover_state(Vec3(5, 5, 5)));
  } catch (const SimulationError& e) {
    reset_error = e.what();
  }
  try {
    sim.step();
  } catch (const SimulationError& e) {
    step_error = e.what();
  }
  try {
    sim.step(10);
  } catch (const SimulationError& e) {
    steps_error = e.what();
  }
  try {
    ControlInput in;
    in.state = before;
    controller.calculate_u(in);
  } catch (const SimulationError& e) {
    controller_error = e.what();
  }
  EXPECT_EQ(sim.state(), before);
  phase.store(2);
  flyer.join();
  EXPECT_NE(reset_error.find("Simulator::reset: this object is in use by another thread"),
            std::string::npos)
      << reset_error;
  EXPECT_NE(step_error.find("Simulator::step"), std::string::npos) << step_error;
  EXPECT_NE(steps_error.find("Simulator::step"), std::string::npos) << steps_error;
  EXPECT_NE(controller_error.find("in use by another thread"), std::string::npos)
      << controller_error;
  // The flight itself was not disturbed: all of it, at hover.
  EXPECT_TRUE(result.ok());
  EXPECT_EQ(result.steps_taken, 100);
  EXPECT_NEAR(sim.state()[2], 1.0, 1e-3);
}

}  // namespace
}  // namespace dronetwin
