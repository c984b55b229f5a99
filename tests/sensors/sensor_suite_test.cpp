// SensorSuite: sample instants and latencies, seeded determinism, independence of the sensors'
// streams, errors naming the sensor and field; make_sensor_truth on a real Simulator (an IMU on
// the ground reads +g, hovering it reads the thrust, in free fall nothing).

#include "dronetwin/sensors/sensor_suite.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

SensorTruth rest_at(double t) {
  SensorTruth truth;
  truth.time_s = t;
  truth.state[2] = 1.0;
  truth.state[6] = 1.0;
  return truth;
}

/// Runs `seconds` at physics step dt, collecting (step time, stamp) of every delivery of sensor i.
std::vector<std::pair<double, double>> deliveries(SensorSuite& suite, int i, double dt,
                                                  double seconds) {
  std::vector<std::pair<double, double>> out;
  const auto n = static_cast<std::int64_t>(std::llround(seconds / dt));
  for (std::int64_t k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) * dt;
    suite.update(k, rest_at(t));
    if (suite.fresh(i)) out.emplace_back(t, suite.latest(i).stamp_s);
  }
  return out;
}

TEST(SensorSuite, RatesThatDoNotDivideThePhysicsRateKeepTheirAverage) {
  SensorSpec cam = SensorSpec::barometer("slow");
  cam.rate_hz = 30.0;
  SensorSuite suite({cam}, 1e-3, 4, 1);
  const auto d = deliveries(suite, 0, 1e-3, 10.0);
  ASSERT_EQ(d.size(), 301u);  // t = 0 .. 10 s inclusive
  for (std::size_t n = 0; n < d.size(); ++n) {
    // Sample n at the first step at or after n / 30 s.
    EXPECT_NEAR(d[n].second, std::ceil(static_cast<double>(n) / 30.0 / 1e-3 - 1e-9) * 1e-3, 1e-12);
  }
}

TEST(SensorSuite, ReadingsArriveAfterTheirLatency) {
  SensorSpec gps = SensorSpec::gps();  // 10 Hz, 0.1 s late
  SensorSpec mocap = SensorSpec::motion_capture();
  mocap.latency_s = 0.0125;  // not a multiple of the step: delivered at the next step
  SensorSuite suite({gps, mocap}, 1e-3, 4, 1);
  std::vector<std::pair<double, double>> g, m;
  for (std::int64_t k = 0; k <= 2000; ++k) {
    suite.update(k, rest_at(static_cast<double>(k) * 1e-3));
    if (suite.fresh(0)) g.emplace_back(static_cast<double>(k) * 1e-3, suite.latest(0).stamp_s);
    if (suite.fresh(1)) m.emplace_back(static_cast<double>(k) * 1e-3, suite.latest(1).stamp_s);
    if (k < 100) {
      EXPECT_FALSE(suite.latest(0).valid()) << "a GPS fix before t = 0.1 s";
    }
  }
  ASSERT_EQ(g.size(), 20u);  // stamps 0 .. 1.9 s delivered by 2.0 s
  for (const auto& [t, stamp] : g) EXPECT_NEAR(t - stamp, 0.1, 1e-12);
  for (const auto& [t, stamp] : m) EXPECT_NEAR(t - stamp, 0.013, 1e-12);
}

std::vector<double> readings(const std::vector<SensorSpec>& specs, int i, std::uint64_t seed) {
  SensorSuite suite(specs, 1e-3, 4, seed);
  std::vector<double> out;
  for (std::int64_t k = 0; k < 500; ++k) {
    suite.update(k, rest_at(static_cast<double>(k) * 1e-3));
    if (suite.fresh(i))
      out.insert(out.end(), suite.latest(i).values.begin(),
                 suite.latest(i).values.begin() + suite.latest(i).size);
  }
  return out;
}

TEST(SensorSuite, SameSeedSameReadingsAndSensorsDoNotDisturbEachOther) {
  const std::vector<SensorSpec> one = {SensorSpec::imu()};
  const std::vector<SensorSpec> three = {SensorSpec::barometer(), SensorSpec::gps(),
                                         SensorSpec::imu()};
  const auto a = readings(one, 0, 42);
  EXPECT_EQ(a.size(), 500u * 6u);
  EXPECT_EQ(a, readings(one, 0, 42));    // bitwise
  EXPECT_EQ(a, readings(three, 2, 42));  // other sensors before it change nothing
  EXPECT_NE(a, readings(one, 0, 43));
  SensorSuite suite(three, 1e-3, 4, 42);
  suite.update(0, rest_at(0.0));
  const SensorReading first = suite.latest(2);
  suite.update(1, rest_at(0.001));
  suite.reset(42);
  suite.update(0, rest_at(0.0));
  EXPECT_EQ(first.values, suite.latest(2).values);  // reset restarts the stream
}

TEST(SensorSuite, BadSpecsNameTheSensorAndField) {
  SensorSpec imu = SensorSpec::imu();
  std::get<ImuParameters>(imu.parameters).gyro.noise_density = -1.0;
  EXPECT_EQ(test::error_of([&] { SensorSuite({imu}, 1e-3, 4, 0); }),
            "sensors[0] (imu): gyro.noise_density: expected a finite number >= 0, got -1");
  SensorSpec fast = SensorSpec::barometer();
  fast.rate_hz = 2000.0;
  EXPECT_NE(test::error_of([&] {
              SensorSuite({fast}, 1e-3, 4, 0);
            }).find("rate_hz: 2000 Hz is faster than the physics step (1000 Hz)"),
            std::string::npos);
  SensorSpec zero = SensorSpec::barometer();
  zero.rate_hz = 0.0;
  EXPECT_EQ(test::error_of([&] { SensorSuite({zero}, 1e-3, 4, 0); }),
            "sensors[0] (baro): rate_hz: expected a finite number > 0, got 0");
  EXPECT_NE(test::error_of([&] {
              SensorSuite({SensorSpec::imu("a"), SensorSpec::gps("a")}, 1e-3, 4, 0);
            }).find("sensors[1] (a): name: 'a' is already the name of another sensor"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] {
              SensorSuite({SensorSpec::imu("Imu 1")}, 1e-3, 4, 0);
            }).find("name: expected 1-32 lower-case letters"),
            std::string::npos);
  SensorSpec range = SensorSpec::range_finder();
  std::get<RangeFinderParameters>(range.parameters).max_range_m = 0.01;
  EXPECT_NE(test::error_of([&] {
              SensorSuite({range}, 1e-3, 4, 0);
            }).find("max_range_m: expected a number > min_range_m, got 0.01"),
            std::string::npos);
  EXPECT_THROW(SensorSpec::defaults("sonar", "s"), InvalidArgument);
}

TEST(SensorSuite, BadSuiteSettingsAreNamed) {
  EXPECT_EQ(test::error_of([&] { SensorSuite({SensorSpec::imu()}, 0.0, 4, 0); }),
            "SensorSuite: physics_dt_s: expected a number > 0, got 0");
  EXPECT_EQ(test::error_of([&] { SensorSuite({SensorSpec::imu()}, 1e-3, 9, 0); }),
            "SensorSuite: num_rotors: expected 1 .. 8, got 9");
  const SensorSuite suite({SensorSpec::imu(), SensorSpec::barometer()}, 1e-3, 4, 0);
  EXPECT_EQ(test::error_of([&] { (void)suite.imu_bias(1); }),
            "imu_bias: sensor 1 ('baro') is a barometer, not an imu");
  EXPECT_EQ(test::error_of([&] { (void)suite.imu_bias(2); }),
            "imu_bias: sensor index 2 out of range (2 sensors)");
}

TEST(SensorSuite, ChannelsNameEveryValue) {
  for (const std::string_view type : kSensorTypeNames) {
    SensorSpec s = SensorSpec::defaults(type, "s");
    s.latency_s = 0.0;
    SensorSuite suite({s}, 1e-3, 6, 0);
    const int channels = static_cast<int>(sensor_channels(s, 6).size());
    // Before the first delivery: every channel there, NaN (what a log row holds then).
    const SensorReading& none = suite.latest(0);
    EXPECT_EQ(none.size, channels) << type;
    EXPECT_FALSE(none.valid());
    for (int j = 0; j < none.size; ++j) EXPECT_TRUE(std::isnan(none.values[j])) << type;
    suite.update(0, rest_at(0.0));
    EXPECT_EQ(suite.latest(0).size, channels) << type;
    EXPECT_TRUE(suite.latest(0).valid()) << type;
  }
}

TEST(SensorTruth, ImuOnARealSimulatorReadsGravityThrustAndFreeFall) {
  auto model = test::load_model("qdrone2");
  Simulator sim(model);
  // On the ground, rotors stopped: held by the ground, the IMU reads +g.
  sim.reset(Simulator::hover_state(Vec3::Zero()));
  StateVector previous = sim.state();
  for (int k = 0; k < 10; ++k) {
    previous = sim.state();
    sim.step();
  }
  Vec3 f, w;
  ideal_imu(Mounting{}, make_sensor_truth(sim, previous), f, w);
  EXPECT_NEAR(f[2], 9.81, 1e-9);
  EXPECT_NEAR(f.head<2>().norm(), 0.0, 1e-9);
  // In the air the specific force is every force but gravity over the mass (the wrench
  // breakdown): hovering, that is the thrust; falling with the rotors stopped, the small negative
  // thrust the model keeps at rest (notes #17), not zero.
  for (const RotorVector& speeds :
       {model->hover_speeds_rad_s(), RotorVector(RotorVector::Zero(4))}) {
    sim.reset(Simulator::hover_state(Vec3(0, 0, 20)), speeds);
    for (int k = 0; k < 100; ++k) sim.step();
    const WrenchBreakdown b = sim.wrench_breakdown();
    const Vec3 want = (b.total().force_B - b[Term::kGravity].force_B) / model->mass_kg();
    ideal_imu(Mounting{}, make_sensor_truth(sim, sim.state()), f, w);
    EXPECT_LT((f - want).norm(), 1e-12 * want.norm() + 1e-15);
  }
}

}  // namespace
}  // namespace dronetwin
