// The batched engine in a wind field (BatchSimulator with SimConfig::wind): every lane flies the
// Simulator's wind for its own mean wind, height and time, with turbulence from its own stream,
// so a lane equals a Simulator seeded with counter_stream_key(seed, lane) to round-off; results
// are bitwise independent of threads and batch size; reset() and set_seed() restart the gusts.

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/noise/counter_normal.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;

SimConfig field_config() {
  SimConfig c;
  c.seed = 21;
  c.environment.wind_W_m_s = Vec3(4.0, 1.0, 0.0);
  c.wind.shear.enabled = true;
  c.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
  c.wind.gusts[0] = {0.3, 0.8, Vec3(0.0, -3.0, 1.0)};
  c.wind.num_gusts = 1;
  return c;
}

// Lane l: its own mean wind and start height, hover rotor speeds held.
Vec3 mean_wind_of(int l) { return Vec3(4.0 - 0.5 * l, 1.0 + 0.25 * l, 0.0); }
StateVector start_of(int l) { return Simulator::hover_state(Vec3(0.1 * l, 0.0, 0.8 + 0.3 * l)); }

void start_lanes(BatchSimulator<double>& batch, const VehicleModel& model) {
  for (int l = 0; l < batch.size(); ++l) {
    batch.reset(l, start_of(l), model.hover_speeds_rad_s());
    batch.set_wind(l, mean_wind_of(l));
  }
}

TEST(BatchWind, EveryLaneEqualsTheSimulatorSeededWithItsStreamKey) {
  const auto model = test::load_model("qdrone2");
  const SimConfig c = field_config();
  constexpr int kLanes = 7, kSteps = test::full_or_sanitized(2000, 500);
  BatchSimulator<double> batch(model, c, kLanes, 2);
  start_lanes(batch, *model);
  std::vector<Simulator> sims;
  for (int l = 0; l < kLanes; ++l) {
    SimConfig lane = c;
    lane.seed = counter_stream_key(c.seed, static_cast<std::uint64_t>(l));
    lane.environment.wind_W_m_s = mean_wind_of(l);
    sims.emplace_back(model, lane);
    sims.back().reset(start_of(l), model->hover_speeds_rad_s());
    sims.back().set_rotor_speed_reference(model->hover_speeds_rad_s());
    ASSERT_LE((batch.air_velocity(l) - sims.back().wind_W_m_s()).norm(), 1e-12);
  }
  for (int k = 0; k < kSteps; ++k) {
    ASSERT_EQ(batch.step(1), 0);
    for (int l = 0; l < kLanes; ++l) {
      Simulator& sim = sims[static_cast<std::size_t>(l)];
      ASSERT_TRUE(sim.step().ok());
      if (k % 250 != 249) continue;
      SCOPED_TRACE(testing::Message() << "lane " << l << " step " << k + 1);
      const StateVector gap = batch.state(l) - sim.state();
      ASSERT_LE(gap.cwiseAbs().maxCoeff(), 1e-9 * (1.0 + sim.state().cwiseAbs().maxCoeff()));
      ASSERT_LE((batch.air_velocity(l) - sim.wind_W_m_s()).norm(), 1e-9);
    }
  }
  // Lanes have their own gusts: two lanes at the same height and mean wind would still differ.
  EXPECT_NE(batch.air_velocity(0) - mean_wind_of(0), batch.air_velocity(1) - mean_wind_of(1));
}

std::vector<double> fly(int n, int threads) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, field_config(), n, threads);
  start_lanes(batch, *model);
  batch.step(1500);
  std::vector<double> out;
  for (int l = 0; l < n; ++l) {
    const StateVector x = batch.state(l);
    out.insert(out.end(), x.data(), x.data() + kStateSize);
  }
  return out;
}

TEST(BatchWind, ResultsAreBitwiseIndependentOfThreadsAndBatchSize) {
  const std::vector<double> one = fly(9, 1), two = fly(9, 2), small = fly(3, 2);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(small.data(), one.data(), small.size() * sizeof(double)), 0);
}

TEST(BatchWind, ResetAndSetSeedRestartTheGusts) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, field_config(), 2, 1);
  start_lanes(batch, *model);
  const Vec3 at_start = batch.air_velocity(1);
  batch.step(700);
  EXPECT_NE(batch.air_velocity(1), at_start);
  batch.reset(1, start_of(1), model->hover_speeds_rad_s());
  EXPECT_EQ(batch.air_velocity(1), at_start);  // the same developed gusts again
  batch.set_seed(1, 99);
  EXPECT_NE(batch.air_velocity(1), at_start);  // a new episode's gusts
  // The mean wind is still the lane's own.
  EXPECT_EQ(batch.wind_data()[batch.stride() + 1], mean_wind_of(1).y());
}

}  // namespace
}  // namespace dronetwin
