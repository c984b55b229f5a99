// Fleet (fleet/fleet.hpp): lockstep without interaction is exactly each vehicle flown alone; the
// wake acts downward only (the vehicle above flies exactly as alone, the one below sags and
// rolls nothing when centred); runs repeat bitwise; vehicles that meet crash together; bad
// fleets are refused by name.

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/fleet/fleet.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;

/// One vehicle: a QDrone2 from `start` holding `target` under SE(3), noise off.
struct Flyer {
  Flyer(const std::shared_ptr<const VehicleModel>& model, const Vec3& start, const Vec3& target,
        double dt_s = 0.001)
      : sim(model, config(dt_s)),
        controller(
            load_controller(test::source_path("config/controllers/se3.yaml"), model, 1.0 / dt_s)),
        reference(target),
        loop(sim, *controller, reference, 1.0 / dt_s) {
    sim.reset(Simulator::hover_state(start), model->hover_speeds_rad_s());
  }
  static SimConfig config(double dt_s) {
    SimConfig c;
    c.dt_s = dt_s;
    return c;
  }
  Simulator sim;
  std::unique_ptr<ControllerBase> controller;
  SetpointReference reference;
  ClosedLoop loop;
};

class FleetTest : public ::testing::Test {
 protected:
  std::shared_ptr<const VehicleModel> model = test::load_model("qdrone2");
};

TEST_F(FleetTest, WithoutDownwashEachVehicleFliesAsAlone) {
  Flyer a(model, Vec3(0, 0, 1), Vec3(1, 0, 1.5));
  Flyer b(model, Vec3(3, 0, 1), Vec3(3, 1, 0.8));
  DownwashSettings off;
  off.enabled = false;
  Fleet fleet(off);
  fleet.add("a", a.sim, a.loop);
  fleet.add("b", b.sim, b.loop);
  const FleetResult r = fleet.run(3.0);
  ASSERT_TRUE(r.ok()) << r.failure_message;
  EXPECT_EQ(r.steps_taken, 3000);
  Flyer a_alone(model, Vec3(0, 0, 1), Vec3(1, 0, 1.5));
  Flyer b_alone(model, Vec3(3, 0, 1), Vec3(3, 1, 0.8));
  ASSERT_TRUE(a_alone.loop.run(3.0).ok());
  ASSERT_TRUE(b_alone.loop.run(3.0).ok());
  EXPECT_EQ(a.sim.state(), a_alone.sim.state());
  EXPECT_EQ(b.sim.state(), b_alone.sim.state());
  EXPECT_EQ(b.sim.rotor_speeds_rad_s(), b_alone.sim.rotor_speeds_rad_s());
}

TEST_F(FleetTest, TheWakeActsDownwardOnlyAndRepeatsBitwise) {
  const auto fly = [&](StateVector& upper_end, StateVector& lower_end, DownwashEffect& felt) {
    Flyer upper(model, Vec3(0, 0, 2.2), Vec3(0, 0, 2.2));
    Flyer lower(model, Vec3(0, 0, 1.0), Vec3(0, 0, 1.0));
    Fleet fleet;
    fleet.add("upper", upper.sim, upper.loop);
    fleet.add("lower", lower.sim, lower.loop);
    ASSERT_TRUE(fleet.run(4.0).ok());
    upper_end = upper.sim.state();
    lower_end = lower.sim.state();
    felt = fleet.downwash(1);
    EXPECT_EQ(fleet.downwash(0).wrench_B, Vector6<double>::Zero());  // nothing above it
    EXPECT_EQ(fleet.downwash(0).flow_W_m_s, Vec3::Zero());
  };
  StateVector upper_end, lower_end, upper_again, lower_again;
  DownwashEffect felt, felt_again;
  fly(upper_end, lower_end, felt);
  fly(upper_again, lower_again, felt_again);
  EXPECT_EQ(upper_end, upper_again);
  EXPECT_EQ(lower_end, lower_again);

  Flyer upper_alone(model, Vec3(0, 0, 2.2), Vec3(0, 0, 2.2));
  Flyer lower_alone(model, Vec3(0, 0, 1.0), Vec3(0, 0, 1.0));
  ASSERT_TRUE(upper_alone.loop.run(4.0).ok());
  ASSERT_TRUE(lower_alone.loop.run(4.0).ok());
  EXPECT_EQ(upper_end, upper_alone.sim.state());
  // The lower one holds lower than alone: SE(3) has no integrator, so it settles where its
  // position gain (K_p,z = 33 N/m, se3.yaml) makes up the force the wake takes, the thrust lost
  // plus the frame drag of the downward flow (A_zz w).
  EXPECT_LT(felt.wrench_B[2], -0.5);
  EXPECT_LT(felt.flow_W_m_s.z(), -1.0);
  const double lost_N = -felt.wrench_B[2] - model->body_drag_Ns_per_m()(2, 2) * felt.flow_W_m_s.z();
  const double sag_m = lower_alone.sim.state()[kPosition + 2] - lower_end[kPosition + 2];
  EXPECT_NEAR(sag_m, lost_N / 33.0, 0.1 * lost_N / 33.0);
}

TEST_F(FleetTest, VehiclesThatMeetCrashTogether) {
  Flyer a(model, Vec3(-1, 0, 1), Vec3(1, 0, 1));
  Flyer b(model, Vec3(1, 0, 1), Vec3(-1, 0, 1));
  Fleet fleet;
  fleet.add("a", a.sim, a.loop);
  fleet.add("b", b.sim, b.loop);
  const FleetResult r = fleet.run(5.0);
  EXPECT_EQ(r.status, StepStatus::kCollided);
  EXPECT_EQ(r.failed_vehicle, 0);
  EXPECT_EQ(r.other_vehicle, 1);
  EXPECT_NE(r.failure_message.find("vehicle 'a': touched vehicle 'b' at t = "), std::string::npos)
      << r.failure_message;
  const double d =
      (a.sim.state().segment<3>(kPosition) - b.sim.state().segment<3>(kPosition)).norm();
  EXPECT_LT(d, fleet.contact_distance_m(0, 1));
  EXPECT_LT(r.steps_taken, 5000);
  EXPECT_EQ(a.sim.step_count(), r.steps_taken);
  EXPECT_EQ(b.sim.step_count(), r.steps_taken);
}

TEST_F(FleetTest, BadFleetsAreRefusedByName) {
  Flyer a(model, Vec3(0, 0, 1), Vec3(0, 0, 1));
  Flyer b(model, Vec3(2, 0, 1), Vec3(2, 0, 1));
  Flyer coarse(model, Vec3(4, 0, 1), Vec3(4, 0, 1), 0.002);
  Fleet fleet;
  fleet.add("a", a.sim, a.loop);
  EXPECT_NE(
      test::error_of([&] { fleet.add("a", b.sim, b.loop); }).find("two vehicles are called 'a'"),
      std::string::npos);
  EXPECT_NE(test::error_of([&] { fleet.add("", b.sim, b.loop); }).find("needs a name"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] {
              fleet.add("b", b.sim, a.loop);
            }).find("its ClosedLoop flies another simulator"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] {
              fleet.add("coarse", coarse.sim, coarse.loop);
            }).find("steps with dt = 0.002 s, but 'a' with 0.001 s"),
            std::string::npos);
  DownwashSettings bad;
  bad.spreading_rate = -0.1;
  EXPECT_NE(test::error_of([&] {
              Fleet f(bad);
            }).find("downwash.spreading_rate: expected a number > 0, got -0.1"),
            std::string::npos);
  // Every other setting, each on its own.
  const auto refused = [](void (*spoil)(DownwashSettings&)) {
    DownwashSettings d;
    spoil(d);
    return test::error_of([&] { Fleet f(d); });
  };
  EXPECT_EQ(refused([](DownwashSettings& d) { d.propeller_radius_m = 0.0; }),
            "downwash.propeller_radius_m: expected a number > 0, got 0");
  EXPECT_EQ(refused([](DownwashSettings& d) { d.thrust_lapse = -0.5; }),
            "downwash.thrust_lapse: expected a number >= 0, got -0.5");
  EXPECT_EQ(refused([](DownwashSettings& d) { d.air_density_kg_m3 = 0.0; }),
            "downwash.air_density_kg_m3: expected a number > 0, got 0");
  Fleet empty;
  EXPECT_NE(test::error_of([&] { (void)empty.run(1.0); }).find("has no vehicles"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
