// The wake model (dynamics/downwash.hpp) against what defines it: a round jet's momentum flux
// through any plane across it is the thrust that drives it (integrated here numerically), its
// half-width grows linearly at the spreading rate, its centre-line decay is within 10 % of
// Pope's measured constant; the wake follows a tilted source and is absent above it; in it, a
// level vehicle loses thrust without a moment when centred and rolls its near side down when
// off the axis; a rotor never loses more than its thrust.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dronetwin/dynamics/downwash.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

WakeSource level_source(double thrust_N, const Vec3& at = Vec3(0.0, 0.0, 3.0)) {
  WakeSource s;
  s.position_W_m = at;
  s.thrust_axis_W = Vec3::UnitZ();
  s.thrust_N = thrust_N;
  s.half_width_m = 0.3;
  return s;
}

TEST(Downwash, MomentumFluxThroughEveryPlaneIsTheThrust) {
  const DownwashSettings settings;
  const WakeSource source = level_source(14.75);
  for (const double below_m : {0.05, 0.5, 1.2, 3.0, 10.0}) {
    // rho int U^2 dA over the plane below_m under the source, by the midpoint rule in r out to
    // where the Gaussian has vanished.
    const double r_max_m = 3.0 * (settings.spreading_rate * below_m + source.half_width_m) * 3.0;
    const int n = 20000;
    const double dr = r_max_m / n;
    double flux_N = 0.0;
    for (int k = 0; k < n; ++k) {
      const double r = (k + 0.5) * dr;
      const Vec3 u =
          wake_velocity_W_m_s(settings, source, source.position_W_m + Vec3(r, 0.0, -below_m));
      flux_N += settings.air_density_kg_m3 * u.squaredNorm() * 2.0 * std::numbers::pi * r * dr;
    }
    EXPECT_NEAR(flux_N / source.thrust_N, 1.0, 1e-7) << below_m << " m below";
  }
}

TEST(Downwash, HalfWidthGrowsAtTheSpreadingRateAndDecayMatchesPope) {
  const DownwashSettings settings;
  const WakeSource source = level_source(14.75);
  const double origin_m = source.half_width_m / settings.spreading_rate;  // above the source
  for (const double below_m : {1.0, 4.0}) {
    const double s_m = below_m + origin_m;
    const Vec3 centre = source.position_W_m - below_m * Vec3::UnitZ();
    const double u_c = wake_velocity_W_m_s(settings, source, centre).norm();
    const double u_half =
        wake_velocity_W_m_s(settings, source, centre + Vec3(0.0, settings.spreading_rate * s_m, 0))
            .norm();
    EXPECT_NEAR(u_half / u_c, 0.5, 1e-12);
    // Pope (Turbulent Flows, Sec. 5.1): U_c = B U_J d / s with B = 5.8 for a jet of momentum
    // flux J = rho U_J^2 pi d^2 / 4.
    const double u_j_d = std::sqrt(4.0 * source.thrust_N / (std::numbers::pi * 1.225));
    const double b = u_c * s_m / u_j_d;
    EXPECT_NEAR(b / 5.8, 1.0, 0.10) << "decay constant " << b;
  }
}

TEST(Downwash, WakeFollowsTheThrustAxisAndIsAbsentAboveTheSource) {
  const DownwashSettings settings;
  WakeSource source = level_source(14.75);
  EXPECT_EQ(wake_velocity_W_m_s(settings, source, source.position_W_m + Vec3(0, 0, 0.5)),
            Vec3::Zero());
  EXPECT_EQ(wake_velocity_W_m_s(settings, source, source.position_W_m), Vec3::Zero());
  source.thrust_N = 0.0;
  EXPECT_EQ(wake_velocity_W_m_s(settings, source, source.position_W_m - Vec3(0, 0, 1)),
            Vec3::Zero());
  // Tilted 30 deg about x: the wake leaves along -b3, and its centre line is there.
  source.thrust_N = 14.75;
  const double a = std::numbers::pi / 6.0;
  source.thrust_axis_W = Vec3(0.0, -std::sin(a), std::cos(a));
  const Vec3 on_axis = source.position_W_m - 1.5 * source.thrust_axis_W;
  const Vec3 u = wake_velocity_W_m_s(settings, source, on_axis);
  EXPECT_NEAR(u.normalized().dot(-source.thrust_axis_W), 1.0, 1e-14);
  const Vec3 straight_below = source.position_W_m - Vec3(0.0, 0.0, 1.5 * std::cos(a));
  EXPECT_LT(wake_velocity_W_m_s(settings, source, straight_below).norm(), u.norm());
}

class DownwashOnAVehicle : public ::testing::Test {
 protected:
  std::shared_ptr<const VehicleModel> model = test::load_model("qdrone2");
  RotorVector hover = model->hover_speeds_rad_s();
  DownwashSettings settings;
  WakeSource source = level_source(14.75);
  DownwashEffect at(const Vec3& p) const {
    return downwash_effect(settings, *model, Simulator::hover_state(p), hover, &source, 1);
  }
};

TEST_F(DownwashOnAVehicle, CentredBelowItLosesThrustWithoutAMoment) {
  const DownwashEffect e = at(source.position_W_m - Vec3(0.0, 0.0, 1.2));
  EXPECT_LT(e.wrench_B[2], -0.5);  // several newtons: the wake is ~5 m/s, v_h ~6 m/s
  EXPECT_NEAR(e.wrench_B[0], 0.0, 1e-12);
  EXPECT_NEAR(e.wrench_B[1], 0.0, 1e-12);
  EXPECT_NEAR(e.wrench_B.tail<3>().norm(), 0.0, 1e-12);
  EXPECT_LT(e.flow_W_m_s.z(), 0.0);
  // Linear in the lapse factor, and nothing at all without it.
  settings.thrust_lapse = 0.25;
  EXPECT_NEAR(at(source.position_W_m - Vec3(0.0, 0.0, 1.2)).wrench_B[2], 0.5 * e.wrench_B[2],
              1e-12);
  settings.thrust_lapse = 0.0;
  EXPECT_EQ(at(source.position_W_m - Vec3(0.0, 0.0, 1.2)).wrench_B, Vector6<double>::Zero());
  settings.enabled = false;
  const DownwashEffect off = at(source.position_W_m - Vec3(0.0, 0.0, 1.2));
  EXPECT_EQ(off.flow_W_m_s, Vec3::Zero());
}

TEST_F(DownwashOnAVehicle, OffTheAxisTheNearSideDrops) {
  // At +y of the wake's axis, the rotors at body -y are nearer the centre line and lose more:
  // M_x = sum dT_i y_i > 0, rolling +y up (the -y side down, into the wake).
  const DownwashEffect e = at(source.position_W_m + Vec3(0.0, 0.3, -1.2));
  EXPECT_GT(e.wrench_B[3], 1e-3);
  EXPECT_NEAR(e.wrench_B[4], 0.0, 1e-12);
  const DownwashEffect minus = at(source.position_W_m + Vec3(0.0, -0.3, -1.2));
  EXPECT_NEAR(minus.wrench_B[3], -e.wrench_B[3], 1e-12);
}

TEST_F(DownwashOnAVehicle, NoRotorLosesMoreThanItsThrust) {
  source.thrust_N = 1e4;  // a wake far faster than the rotors' own induced velocity
  const DownwashEffect e = at(source.position_W_m - Vec3(0.0, 0.0, 0.2));
  double thrust_N = 0.0;
  for (int i = 0; i < model->num_rotors(); ++i) thrust_N += model->rotor(i).thrust(hover[i]);
  EXPECT_NEAR(e.wrench_B[2], -thrust_N, 1e-9);
  // Far to the side, nothing: the Gaussian has underflowed.
  EXPECT_EQ(at(source.position_W_m + Vec3(40.0, 0.0, -1.0)).wrench_B, Vector6<double>::Zero());
}

}  // namespace
}  // namespace dronetwin
