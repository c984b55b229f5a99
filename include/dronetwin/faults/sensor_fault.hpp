#pragma once
// Sensor faults (docs/faults.md): over a window of time a sensor
//   - drops out: the samples it takes are lost (never delivered), so whoever reads it keeps its
//     last reading and sees nothing fresh (a cable that lost contact, motion-capture occlusion);
//   - has a bias step: `value` (in the channel's unit) is added to one channel of every sample
//     it takes (a knocked IMU, a barometer port in the prop wash, a GPS jump).
// Noise and bias processes run on through a fault, so outside its window a faulty sensor reads
// exactly what the healthy one would. Settings are plain data (SensorSpec::faults), applied by
// the SensorSuite; the estimator reading the sensor is not told.
//
//   SensorSpec mocap = SensorSpec::motion_capture();
//   mocap.faults.push_back(SensorFault::dropout(10.0, 12.0));
//   SensorSpec imu = SensorSpec::imu();
//   imu.faults.push_back(SensorFault::bias_step(20.0, "wz", 0.05));   // +0.05 rad/s on gyro z
//
// A fault acts on the samples whose stamps t satisfy start_s - dt/2 <= t < end_s - dt/2 (the
// physics steps nearest its start and end, as rotor faults).

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

namespace dronetwin {

enum class SensorFaultKind { kDropout, kBiasStep };

/// YAML and Python names, in the order of SensorFaultKind.
inline constexpr std::array<std::string_view, 2> kSensorFaultNames = {"dropout", "bias_step"};

struct SensorFault {
  SensorFaultKind kind = SensorFaultKind::kDropout;
  double start_s = 0.0;
  /// When the fault ends; +infinity: never.
  double end_s = std::numeric_limits<double>::infinity();
  /// kBiasStep: the channel's log-column suffix (sensor_channels(): "wz", "p", "x", "w2", ...).
  std::string channel;
  /// kBiasStep: added to the channel, in its unit.
  double value = 0.0;

  static SensorFault dropout(double start_s,
                             double end_s = std::numeric_limits<double>::infinity()) {
    return {SensorFaultKind::kDropout, start_s, end_s, {}, 0.0};
  }
  static SensorFault bias_step(double start_s, std::string channel, double value,
                               double end_s = std::numeric_limits<double>::infinity()) {
    return {SensorFaultKind::kBiasStep, start_s, end_s, std::move(channel), value};
  }

  std::string_view type_name() const { return kSensorFaultNames[static_cast<std::size_t>(kind)]; }
  /// True for a sample stamped `stamp_s` on a physics step of length `dt_s`.
  bool active_at(double stamp_s, double dt_s) const {
    return stamp_s >= start_s - 0.5 * dt_s && stamp_s < end_s - 0.5 * dt_s;
  }
};

/// Faults one sensor may carry: a bound so that a file cannot ask for unbounded work per sample.
inline constexpr std::size_t kMaxSensorFaults = 16;

}  // namespace dronetwin
