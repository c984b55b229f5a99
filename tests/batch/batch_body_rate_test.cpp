// The batched body-rate (CTBR) controller against BodyRateController flown by ClosedLoop at the
// physics rate: in double every lane is the same flight (per-lane commands changed every 100
// steps, as a 10 Hz policy would), and non-finite commands stop their lane alone.

#include "dronetwin/batch/batch_body_rate.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

struct Command {
  double thrust_N;
  Vec3 rates;
};

TEST(BatchBodyRate, EveryLaneEqualsTheClosedLoopWithTheScalarController) {
  const auto model = test::load_model("qdrone2");
  constexpr int N = 11, kSegments = 15, kSegmentSteps = 100;
  SimConfig cfg;
  BatchSimulator<double> batch(model, cfg, N, 2);
  BatchBodyRateController<double> rates(model, BodyRateGains{}, N);
  Random rng(12);
  const double hover = model->mass_kg() * 9.81;
  std::vector<std::vector<Command>> commands(N);
  std::vector<double> yaws;
  for (int l = 0; l < N; ++l) {
    for (int k = 0; k < kSegments; ++k)
      commands[static_cast<std::size_t>(l)].push_back(
          {hover * (0.8 + 0.5 * rng.uniform()), Vec3(rng.normal(), rng.normal(), rng.normal())});
    yaws.push_back(rng.normal());
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 5.0), yaws.back()),
                model->hover_speeds_rad_s());
  }
  for (int k = 0; k < kSegments; ++k) {
    for (int l = 0; l < N; ++l) {
      const Command& c = commands[static_cast<std::size_t>(l)][static_cast<std::size_t>(k)];
      rates.set_command(l, c.thrust_N, c.rates);
    }
    ASSERT_EQ(batch.step(kSegmentSteps, rates), 0);
  }
  double worst = 0.0;
  for (int l = 0; l < N; ++l) {
    Simulator sim(model, cfg);
    sim.reset(Simulator::hover_state(Vec3(0, 0, 5.0), yaws[static_cast<std::size_t>(l)]),
              model->hover_speeds_rad_s());
    BodyRateController scalar(model, BodyRateGains{});
    const SetpointReference unused(Vec3::Zero());
    ClosedLoop loop(sim, scalar, unused, 1.0 / cfg.dt_s);
    for (int k = 0; k < kSegments; ++k) {
      const Command& c = commands[static_cast<std::size_t>(l)][static_cast<std::size_t>(k)];
      scalar.set_command(c.thrust_N, c.rates);
      for (int s = 0; s < kSegmentSteps; ++s) ASSERT_TRUE(loop.step().ok());
    }
    const StateVector a = batch.state(l), b = sim.state();
    for (int i = 0; i < kStateSize; ++i)
      worst = std::max(worst, std::abs(a[i] - b[i]) / (1.0 + std::abs(b[i])));
  }
  std::printf("[ batch    ] CTBR batch vs ClosedLoop, 11 lanes x 1.5 s: worst relative gap %.3g\n",
              worst);
  EXPECT_LE(worst, 1e-12);
}

TEST(BatchBodyRate, ANonFiniteCommandStopsItsLaneAlone) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<float> batch(model, SimConfig{}, 9);
  BatchBodyRateController<float> rates(model, BodyRateGains{}, 9);
  for (int l = 0; l < 9; ++l) {
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
    rates.set_command(l, model->mass_kg() * 9.81, Vec3::Zero());
  }
  rates.command_data()[2 * rates.stride() + 7] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(batch.step(50, rates), 1);
  EXPECT_EQ(batch.status(7), StepStatus::kControllerFailed);
  for (int l = 0; l < 9; ++l) {
    if (l == 7) continue;
    EXPECT_EQ(batch.status(l), StepStatus::kOk);
    EXPECT_NEAR(batch.state(l)[2], 1.0, 1e-3) << "lane " << l << " holds its altitude";
  }
  EXPECT_NE(test::error_of([&] { rates.set_command(9, 1.0, Vec3::Zero()); }).find("out of range"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { rates.set_command(1, -2.0, Vec3::Zero()); }).find("thrust"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
