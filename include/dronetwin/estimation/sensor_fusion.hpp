#pragma once
// The error-state EKF fed by a SensorSuite: the IMU's samples propagate it, the readings of the
// other chosen sensors correct it as they are delivered, each with the noise its own
// configuration states (docs/sensors.md, "Estimation").
//
//   SensorFusion fusion(suite.specs(), {"imu", {"mocap"}}, initial_state);
//   ... every physics step, after suite.update(...):
//   fusion.process(suite);
//   StateVector x_hat = fusion.estimate();
//
// Updates per sensor type:
//   motion_capture  position (with the mounting's lever arm) and attitude q_WB = q_WS q_BS^-1
//   gps             position (lever arm) and velocity; sigma: the largest axis of white and
//                   wandering error together (the wandering part is treated as white: the filter
//                   is optimistic about GPS, see docs/sensors.md)
//   barometer       height from the ISA altitude of the pressure, sigma from noise_Pa / (rho g)
//   magnetometer    field minus the configured hard iron, against the configured world field
//   range_finder    distance to flat ground; readings with no return are skipped
//   optical_flow    image flow over flat ground with the last gyro rates (no reading: skipped)
// Readings are applied when delivered; a late position or attitude is first carried forward by
// its age with the estimated velocity and rates (first order; the covariance is not corrected).

#include <string>
#include <vector>

#include "dronetwin/estimation/error_state_ekf.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"

namespace dronetwin {

struct FusionSettings {
  /// Name of the IMU that drives the propagation.
  std::string imu;
  /// Names of the sensors whose readings correct the estimate.
  std::vector<std::string> updates;
};

class SensorFusion {
 public:
  /// Resolves the names against `specs` (InvalidArgument naming the setting: an unknown name, an
  /// IMU that is not an imu, an update sensor of a type the filter cannot use); the filter starts
  /// at `initial_state` with its default initial uncertainty.
  SensorFusion(const std::vector<SensorSpec>& specs, const FusionSettings& settings,
               const StateVector& initial_state);

  /// Consumes the readings `suite` delivered in its last update().
  void process(const SensorSuite& suite);

  /// [p, v, q, w] (w: the last bias-corrected gyro rate).
  const StateVector& estimate() const { return estimate_; }
  const ErrorStateEkf& filter() const { return ekf_; }
  /// Updates applied so far.
  std::int64_t updates() const { return updates_; }

 private:
  struct Update {
    int sensor = 0;
    std::size_t type = 0;  ///< index into kSensorTypeNames
  };
  std::vector<SensorSpec> specs_;
  int imu_ = 0;  ///< before ekf_: its parameters come from this sensor
  std::vector<Update> update_;
  ErrorStateEkf ekf_;
  double last_imu_stamp_s_ = 0.0;
  bool imu_started_ = false;
  StateVector estimate_;
  std::int64_t updates_ = 0;
};

}  // namespace dronetwin
