// Sensor faults in the SensorSuite (faults/sensor_fault.hpp): a faulty sensor against a healthy
// one with the same seed. A dropout loses exactly the samples stamped in its window and leaves
// every other reading bitwise as it was; a bias step adds its value to its one channel inside its
// window and nowhere else; bad faults are named.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kDt = 1e-3;

/// A vehicle turning at 1 rad/s about z at 1 m: the readings change from sample to sample.
SensorTruth turning_at(double t) {
  SensorTruth truth;
  truth.time_s = t;
  truth.state[2] = 1.0;
  truth.state[6] = std::cos(0.5 * t);
  truth.state[9] = std::sin(0.5 * t);
  truth.state[12] = 1.0;
  return truth;
}

struct Delivery {
  double step_time_s, stamp_s;
  std::vector<double> values;
};

/// Every delivery of sensor 0 over `seconds`, and for each step whether it was fresh.
std::vector<Delivery> run(const SensorSpec& spec, double seconds, int rotors = 4) {
  SensorSuite suite({spec}, kDt, rotors, 17);
  std::vector<Delivery> out;
  const auto n = static_cast<std::int64_t>(std::llround(seconds / kDt));
  for (std::int64_t k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) * kDt;
    suite.update(k, turning_at(t));
    if (!suite.fresh(0)) continue;
    const SensorReading& r = suite.latest(0);
    out.push_back({t, r.stamp_s, {r.values.begin(), r.values.begin() + r.size}});
  }
  return out;
}

TEST(SensorSuiteFaults, DropoutLosesTheSamplesInItsWindowAndNothingElse) {
  const SensorSpec healthy = SensorSpec::motion_capture();  // 100 Hz, 5 ms late
  SensorSpec faulty = healthy;
  faulty.faults.push_back(SensorFault::dropout(1.0, 1.5));
  const auto a = run(healthy, 3.0), b = run(faulty, 3.0);
  // 301 samples stamped 0 .. 3 s, less the one at 3 s still in flight; 50 (1.00 .. 1.49 s) lost.
  ASSERT_EQ(a.size(), 300u);
  ASSERT_EQ(b.size(), 250u);
  std::size_t j = 0;
  for (const Delivery& d : a) {
    if (d.stamp_s >= 1.0 - 0.5 * kDt && d.stamp_s < 1.5 - 0.5 * kDt) continue;
    ASSERT_LT(j, b.size());
    EXPECT_EQ(b[j].stamp_s, d.stamp_s);
    EXPECT_EQ(b[j].step_time_s, d.step_time_s);
    EXPECT_EQ(b[j].values, d.values) << "at " << d.stamp_s;  // bitwise: the stream ran on
    ++j;
  }
  EXPECT_EQ(j, b.size());
  // Across the gap the reader holds the last reading from before it.
  SensorSuite suite({faulty}, kDt, 4, 17);
  for (std::int64_t k = 0; k <= 1400; ++k)
    suite.update(k, turning_at(static_cast<double>(k) * kDt));
  EXPECT_NEAR(suite.latest(0).stamp_s, 0.99, 1e-12);
  EXPECT_FALSE(suite.fresh(0));
}

TEST(SensorSuiteFaults, ADropoutWithoutAnEndLastsAndOneFromTheStartDeliversNothing) {
  SensorSpec gps = SensorSpec::gps();
  gps.faults.push_back(SensorFault::dropout(0.0));
  EXPECT_TRUE(run(gps, 2.0).empty());
  SensorSpec later = SensorSpec::gps();
  later.faults.push_back(SensorFault::dropout(0.5));
  const auto d = run(later, 2.0);
  ASSERT_EQ(d.size(), 5u);  // 10 Hz: 0, 0.1, ..., 0.4 s
  EXPECT_NEAR(d.back().stamp_s, 0.4, 1e-12);
}

TEST(SensorSuiteFaults, BiasStepAddsItsValueToItsChannelInItsWindow) {
  const SensorSpec healthy = SensorSpec::imu();  // 1 kHz: channels fx fy fz wx wy wz
  SensorSpec faulty = healthy;
  faulty.faults.push_back(SensorFault::bias_step(0.2, "wz", 0.05, 0.4));
  faulty.faults.push_back(SensorFault::bias_step(0.3, "fx", -0.7));
  const auto a = run(healthy, 1.0), b = run(faulty, 1.0);
  ASSERT_EQ(a.size(), b.size());
  int stepped_wz = 0, stepped_fx = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double t = a[i].stamp_s;
    ASSERT_EQ(b[i].stamp_s, t);
    const bool wz_on = t >= 0.2 - 0.5 * kDt && t < 0.4 - 0.5 * kDt;
    const bool fx_on = t >= 0.3 - 0.5 * kDt;
    for (std::size_t c = 0; c < 6; ++c) {
      const double expected = c == 5 && wz_on ? 0.05 : c == 0 && fx_on ? -0.7 : 0.0;
      if (expected == 0.0) {
        EXPECT_EQ(b[i].values[c], a[i].values[c]) << "channel " << c << " at " << t;
      } else {
        // Adding in floating point: exact to a rounding of the reading.
        EXPECT_NEAR(b[i].values[c] - a[i].values[c], expected,
                    1e-15 * std::abs(a[i].values[c]) + 1e-15);
      }
    }
    stepped_wz += wz_on;
    stepped_fx += fx_on;
  }
  EXPECT_EQ(stepped_wz, 200);
  EXPECT_EQ(stepped_fx, 701);
}

TEST(SensorSuiteFaults, BiasStepOnARotorSpeedChannel) {
  SensorSpec rpm = SensorSpec::rotor_speed();
  rpm.faults.push_back(SensorFault::bias_step(0.0, "w5", 100.0));
  const auto a = run(SensorSpec::rotor_speed(), 0.1, 6), b = run(rpm, 0.1, 6);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_NEAR(b[i].values[5] - a[i].values[5], 100.0, 1e-12);
  // The same file on a four-rotor vehicle names the channel it lacks.
  EXPECT_EQ(test::error_of([&] { SensorSuite({rpm}, kDt, 4, 0); }),
            "sensors[0] (rpm): faults[0].channel: 'w5' is not a channel of 4 rotors "
            "(4 channels: w0 .. w3)");
}

TEST(SensorSuiteFaults, BadFaultsNameTheSensorFaultAndField) {
  const auto error = [](SensorSpec s) {
    return test::error_of([&] { SensorSuite({s}, kDt, 4, 0); });
  };
  SensorSpec baro = SensorSpec::barometer();
  baro.faults.push_back(SensorFault::bias_step(1.0, "q", 10.0));
  EXPECT_EQ(error(baro),
            "sensors[0] (baro): faults[0].channel: expected a channel of a barometer (p), got 'q'");
  baro.faults[0] = SensorFault::bias_step(1.0, "p", std::nan(""));
  EXPECT_EQ(error(baro), "sensors[0] (baro): faults[0].value: expected a finite number, got nan");
  SensorSpec mocap = SensorSpec::motion_capture();
  mocap.faults.push_back(SensorFault::dropout(-1.0, 2.0));
  EXPECT_EQ(error(mocap),
            "sensors[0] (mocap): faults[0].start_s: expected a finite number >= 0, got -1");
  mocap.faults[0] = SensorFault::dropout(2.0, 2.0);
  EXPECT_EQ(error(mocap),
            "sensors[0] (mocap): faults[0].end_s: expected a time at least one physics step "
            "after start_s (or none: the fault lasts), got 2");
  mocap.faults[0] = SensorFault::dropout(2.0, 3.0);
  mocap.faults[0].channel = "x";
  EXPECT_EQ(error(mocap),
            "sensors[0] (mocap): faults[0].channel: a dropout loses whole samples and has no "
            "channel or value, got 'x' and 0");
  SensorSpec many = SensorSpec::imu();
  many.faults.assign(kMaxSensorFaults + 1, SensorFault::dropout(1.0));
  EXPECT_EQ(error(many),
            "sensors[0] (imu): faults: expected at most 16 faults on one sensor, got 17");
  SensorSpec rpm = SensorSpec::rotor_speed();
  rpm.faults.push_back(SensorFault::bias_step(1.0, "w9", 1.0));
  EXPECT_EQ(error(rpm),
            "sensors[0] (rpm): faults[0].channel: expected a channel of a rotor_speed (w0, w1, "
            "w2, w3, ... one per rotor), got 'w9'");
}

}  // namespace
}  // namespace dronetwin
