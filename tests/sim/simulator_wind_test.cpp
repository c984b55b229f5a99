// A simulator in a wind field (SimConfig::wind, docs/wind.md): each step flies in the wind that
// the field's pieces give at the step's start (mean wind sheared to the height, 1 - cos gusts,
// Dryden turbulence along the mean wind's axes), computed here independently from those pieces;
// turbulence is seeded and leaves the OU noise's stream alone; bad settings name their field.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;
using state_index::kVelocity;

WindSettings shear_and_gusts() {
  WindSettings w;
  w.shear.enabled = true;
  w.gusts[0] = {0.5, 1.0, Vec3(0.0, 4.0, -1.0)};
  w.gusts[1] = {1.2, 0.6, Vec3(-3.0, 0.0, 0.0)};
  w.num_gusts = 2;
  return w;
}

Simulator hovering(std::shared_ptr<const VehicleModel> model, const SimConfig& c) {
  Simulator sim(model, c);
  sim.reset(Simulator::hover_state(Vec3(0.0, 0.0, 1.5)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  return sim;
}

// The field against a plain simulator whose constant wind is set by hand before every step to
// the mean wind sheared to its height plus the gusts at its time: the same flight, bit for bit.
TEST(SimulatorWind, ShearAndGustsAreTheWindOfEachStep) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.environment.wind_W_m_s = Vec3(3.0, 1.0, 0.0);
  SimConfig field = c;
  field.wind = shear_and_gusts();
  Simulator a = hovering(model, field), b = hovering(model, c);
  for (int k = 0; k < 2500; ++k) {
    const Vec3 wind =
        mean_wind_at(c.environment.wind_W_m_s, field.wind.shear, b.state()[kPosition + 2]) +
        gust_at(field.wind, b.time_s());
    b.set_wind(wind);
    ASSERT_EQ(a.wind_W_m_s(), wind) << "step " << k;
    if (k == 1000) {  // the first gust at its peak: the derivative sees the same wind
      ASSERT_EQ(a.state_derivative(), b.state_derivative());
      ASSERT_EQ(a.wrench_breakdown().total().force_B, b.wrench_breakdown().total().force_B);
    }
    ASSERT_TRUE(a.step().ok());
    ASSERT_TRUE(b.step().ok());
    ASSERT_EQ(a.state(), b.state()) << "step " << k;
  }
  // The gusts pushed the vehicle: it moved along +y (first gust) by more than the mean wind alone
  // (1 m/s sheared down at 1.5 m) would have in the same time.
  EXPECT_GT(a.state()[kPosition + 1], 0.1);
}

// Turbulence: the wind of each step is the mean plus the turbulence axes times the Dryden gusts
// of filters started from the simulator's turbulence stream and stepped with the height and
// airspeed of each step's start.
TEST(SimulatorWind, TurbulenceIsTheDrydenFiltersAtTheVehicle) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.seed = 11;
  c.environment.wind_W_m_s = Vec3(4.0, -3.0, 0.0);
  c.wind.shear.enabled = true;
  c.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kSevere);
  Simulator sim = hovering(model, c);
  Random rng(turbulence_stream_seed(c.seed));
  DrydenState filters = dryden_start(rng);
  const double w20 = c.wind.turbulence.wind_at_20ft_m_s;
  double sum_sq_u = 0.0;
  const int n = 3000;
  for (int k = 0; k < n; ++k) {
    const double h = sim.state()[kPosition + 2];
    const Vec3 mean = mean_wind_at(c.environment.wind_W_m_s, c.wind.shear, h);
    const DrydenScales scales = dryden_low_altitude(h, w20);
    const Vec3 gust = dryden_gust(filters, scales);
    const Vec3 expected = mean + turbulence_axes(mean) * gust;
    ASSERT_LE((sim.wind_W_m_s() - expected).norm(), 1e-12) << "step " << k;
    sum_sq_u += gust.x() * gust.x();
    const double airspeed = (sim.state().segment<3>(kVelocity) - mean).norm();
    ASSERT_TRUE(sim.step().ok()) << sim.failure_message();
    (void)dryden_step(filters, scales, airspeed, c.dt_s, rng);
  }
  // Developed from the first step (dryden_start): the rms u gust over these 3 s is a sizeable part
  // of sigma_u (its correlation time L_u / V is several seconds, so not all of it).
  const double sigma_u = dryden_low_altitude(1.5, w20).sigma_m_s.x();
  EXPECT_GT(std::sqrt(sum_sq_u / n), 0.05 * sigma_u);
}

TEST(SimulatorWind, TurbulenceIsSeededAndLeavesTheNoiseStreamAlone) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.seed = 5;
  c.noise.enabled = true;
  c.environment.wind_W_m_s = Vec3(2.0, 0.0, 0.0);
  SimConfig turbulent = c;
  turbulent.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
  Simulator calm = hovering(model, c), a = hovering(model, turbulent),
            again = hovering(model, turbulent);
  ASSERT_TRUE(calm.step(500).ok());
  ASSERT_TRUE(a.step(500).ok());
  ASSERT_TRUE(again.step(500).ok());
  EXPECT_EQ(a.state(), again.state());  // same seed, same run
  EXPECT_NE(a.state(), calm.state());   // the turbulence acted
  // The OU noise drew the same samples with and without turbulence.
  EXPECT_EQ(a.data().state_noise.value(), calm.data().state_noise.value());
  EXPECT_EQ(a.data().derivative_noise.value(), calm.data().derivative_noise.value());
  // Another seed, other gusts.
  turbulent.seed = 6;
  Simulator other = hovering(model, turbulent);
  ASSERT_TRUE(other.step(500).ok());
  EXPECT_NE(other.wind_W_m_s(), a.wind_W_m_s());
  // reset() starts the same gusts again.
  a.reset(Simulator::hover_state(Vec3(0.0, 0.0, 1.5)), model->hover_speeds_rad_s());
  const Simulator fresh = hovering(model, SimConfig(a.config()));
  EXPECT_EQ(a.wind_W_m_s(), fresh.wind_W_m_s());
}

TEST(SimulatorWind, SetWindFieldActsFromTheNextStep) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.environment.wind_W_m_s = Vec3(1.0, 0.0, 0.0);
  Simulator sim = hovering(model, c);
  EXPECT_EQ(sim.wind_W_m_s(), c.environment.wind_W_m_s);  // no field: the mean wind
  WindSettings w;
  w.gusts[0] = {0.0, 2.0, Vec3(0.0, 0.0, 2.0)};
  w.num_gusts = 1;
  ASSERT_TRUE(sim.step(500).ok());
  sim.set_wind_field(w);
  EXPECT_EQ(sim.wind_W_m_s(), c.environment.wind_W_m_s + gust_at(w, 0.5));
  EXPECT_NEAR(sim.wind_W_m_s().z(), 1.0, 1e-12);  // half the peak a quarter into the gust
  sim.set_wind(Vec3(0.0, 2.0, 0.0));
  EXPECT_EQ(sim.wind_W_m_s(), Vec3(0.0, 2.0, 0.0) + gust_at(w, 0.5));
}

std::string error_of(const SimConfig& c) {
  try {
    validate(c);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "no error";
}

TEST(SimulatorWind, BadSettingsAreRefusedNamingTheField) {
  SimConfig c;
  c.wind.gusts[1].duration_s = 0.0;
  c.wind.num_gusts = 2;
  EXPECT_NE(error_of(c).find("wind.gusts[1].duration_s: expected > 0, got 0"), std::string::npos)
      << error_of(c);
  c = SimConfig{};
  c.wind.num_gusts = kMaxGusts + 1;
  EXPECT_NE(error_of(c).find("wind.num_gusts: expected 0 .. 8, got 9"), std::string::npos);
  c = SimConfig{};
  c.wind.turbulence = {true, -1.0};
  EXPECT_NE(error_of(c).find("wind.turbulence.wind_at_20ft_m_s: expected a speed >= 0, got -1"),
            std::string::npos);
  c = SimConfig{};
  c.wind.shear.reference_height_m = 0.05;
  EXPECT_NE(error_of(c).find("wind.shear.reference_height_m: expected above twice the roughness"),
            std::string::npos);
  c = SimConfig{};
  c.wind.gusts[0].amplitude_W_m_s.y() = std::nan("");
  c.wind.num_gusts = 1;
  EXPECT_NE(error_of(c).find("wind.gusts[0].amplitude_m_s: expected finite numbers"),
            std::string::npos);
  // The same checks mid-run; the simulator keeps its settings.
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, SimConfig{});
  WindSettings bad;
  bad.turbulence = {true, std::nan("")};
  EXPECT_THROW(sim.set_wind_field(bad), InvalidArgument);
  EXPECT_FALSE(sim.config().wind.varies());
}

}  // namespace
}  // namespace dronetwin
