#pragma once
// The sensors on a vehicle: each with its own type, rate, latency, mounting and noise, sampled
// from the true motion at the physics steps and delivered after its latency. Seeded and
// deterministic: every sensor draws from its own random stream, seeded from the run's seed and
// the sensor's name, so adding or reordering sensors changes no other sensor's readings, and the
// simulator's own noise (the thesis's OU state noise, the `meas_*` columns) is untouched.
//
//   SensorSuite suite({SensorSpec::imu("imu"), SensorSpec::barometer("baro")}, sim.config().dt_s,
//                     model.num_rotors(), /*seed=*/7);
//   StateVector previous = sim.state();
//   suite.update(0, make_sensor_truth(sim, previous));        // samples at t = 0
//   for (...) { previous = sim.state(); sim.step();
//               suite.update(sim.step_count(), make_sensor_truth(sim, previous)); }
//   const SensorReading& imu = suite.latest(0);               // what a flight stack has now
//
// Faults (SensorSpec::faults): a sample taken in a dropout is drawn and then lost; a bias step
// adds its value to the sample before it waits out the latency.
//
// Timing: sample n of a sensor with rate f is taken at the first physics step whose time k dt
// reaches n / f (so 30 Hz at 1 kHz alternates 33- and 34-step gaps and never drifts), stamped
// with that step's time, and delivered at the first step whose time reaches stamp + latency.
// latest() is the most recently delivered sample (stamp NaN before the first). No allocation
// after construction. Formats: docs/sensors.md.

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "dronetwin/faults/sensor_fault.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/barometer.hpp"
#include "dronetwin/sensors/gps.hpp"
#include "dronetwin/sensors/imu.hpp"
#include "dronetwin/sensors/magnetometer.hpp"
#include "dronetwin/sensors/motion_capture.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/optical_flow.hpp"
#include "dronetwin/sensors/range_finder.hpp"
#include "dronetwin/sensors/rotor_speed_sensor.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

using SensorParameters = std::variant<ImuParameters, MagnetometerParameters, BarometerParameters,
                                      GpsParameters, MotionCaptureParameters, RangeFinderParameters,
                                      OpticalFlowParameters, RotorSpeedSensorParameters>;

/// The YAML `type:` names, in the order of SensorParameters' alternatives.
inline constexpr std::array<std::string_view, 8> kSensorTypeNames = {
    "imu",          "magnetometer", "barometer",  "gps", "motion_capture",
    "range_finder", "optical_flow", "rotor_speed"};
/// The name each type gets when none is given (same order): the factories' default argument,
/// and an experiment file's sensor without `name:`.
inline constexpr std::array<std::string_view, 8> kSensorDefaultNames = {
    "imu", "mag", "baro", "gps", "mocap", "range", "flow", "rpm"};

struct SensorSpec {
  /// Names the sensor's log columns (<name>_<channel>): lower-case letters, digits and '_',
  /// starting with a letter; unique on a vehicle.
  std::string name;
  double rate_hz = 100.0;
  double latency_s = 0.0;
  Mounting mounting{};
  SensorParameters parameters = ImuParameters{};
  /// Dropouts and bias steps (faults/sensor_fault.hpp), at most kMaxSensorFaults.
  std::vector<SensorFault> faults;

  std::string_view type_name() const { return kSensorTypeNames[parameters.index()]; }

  /// A sensor of each type with its datasheet-class defaults (rate, latency, mounting, noise).
  static SensorSpec imu(std::string name = std::string(kSensorDefaultNames[0]));
  static SensorSpec magnetometer(std::string name = std::string(kSensorDefaultNames[1]));
  static SensorSpec barometer(std::string name = std::string(kSensorDefaultNames[2]));
  static SensorSpec gps(std::string name = std::string(kSensorDefaultNames[3]));
  static SensorSpec motion_capture(std::string name = std::string(kSensorDefaultNames[4]));
  static SensorSpec range_finder(std::string name = std::string(kSensorDefaultNames[5]));
  static SensorSpec optical_flow(std::string name = std::string(kSensorDefaultNames[6]));
  static SensorSpec rotor_speed(std::string name = std::string(kSensorDefaultNames[7]));
  /// The defaults of the type named `type` (kSensorTypeNames); InvalidArgument otherwise.
  static SensorSpec defaults(std::string_view type, std::string name);
};

/// One channel of a sensor's reading: its log-column suffix, unit and meaning.
struct SensorChannel {
  std::string suffix, unit, meaning;
};
/// The channels of `spec` (rotor_speed: one per rotor), in reading order.
std::vector<SensorChannel> sensor_channels(const SensorSpec& spec, int num_rotors);

/// The index in sensor_channels(spec, num_rotors) of the channel whose suffix is `suffix`, or -1.
int sensor_channel_index(const SensorSpec& spec, int num_rotors, std::string_view suffix);

/// Throws InvalidArgument "<field>: expected ..., got ..." (field relative to the sensor, e.g.
/// "gyro.noise_density", "rate_hz", "faults[0].channel") for a setting out of range or not
/// finite; `physics_dt_s` bounds the rate (at most one sample per physics step). A bias step's
/// channel is checked against the most rotors a vehicle has (the suite checks its own count).
void validate(const SensorSpec& spec, double physics_dt_s);

/// Largest number of values in one reading (the rotor count's maximum).
inline constexpr int kMaxSensorValues = kMaxRotors;

struct SensorReading {
  /// Time the sample was taken, s; NaN while nothing has been delivered.
  double stamp_s = std::numeric_limits<double>::quiet_NaN();
  /// Values in use: the sensor's channel count (sensor_channels()), also before the first
  /// delivery, when every value is NaN.
  int size = 0;
  std::array<double, kMaxSensorValues> values{};
  bool valid() const { return stamp_s == stamp_s; }
};

class SensorSuite {
 public:
  /// Validates every spec (messages start "sensors[i] (<name>): "), checks names are unique.
  SensorSuite(std::vector<SensorSpec> specs, double physics_dt_s, int num_rotors,
              std::uint64_t seed);

  int size() const { return static_cast<int>(specs_.size()); }
  const std::vector<SensorSpec>& specs() const { return specs_; }
  /// Restarts at step 0: streams reseeded, biases redrawn, nothing pending or delivered.
  void reset(std::uint64_t seed);
  /// Takes the samples due at physics step `step` (truth at that step) and delivers those whose
  /// latency has passed. Steps must come in order, each once (0, 1, 2, ...).
  void update(std::int64_t step, const SensorTruth& truth);
  /// The most recently delivered reading of sensor i (stamp and values NaN before the first).
  const SensorReading& latest(int i) const { return runtime_[static_cast<std::size_t>(i)].latest; }
  /// True when sensor i delivered a reading in the last update().
  bool fresh(int i) const { return runtime_[static_cast<std::size_t>(i)].fresh; }
  /// The IMU's current bias (gyro, accel) of sensor i, for tests and estimator checks;
  /// InvalidArgument when sensor i is not an IMU.
  std::pair<Vec3, Vec3> imu_bias(int i) const;

 private:
  using SensorState = std::variant<ImuState, BarometerState, GpsState, std::monostate>;
  struct Runtime {
    Random rng;
    SensorState state;
    std::int64_t next_sample = 0;  ///< index n of the next sample
    std::int64_t next_step = 0;    ///< physics step that takes it
    double last_stamp_s = 0.0;
    std::vector<SensorReading> pending;  ///< ring buffer, capacity fixed at construction
    std::size_t head = 0, count = 0;
    int size = 0;  ///< values per reading
    SensorReading latest;
    bool fresh = false;
    std::vector<int> fault_channel;  ///< per fault: the bias step's value index (-1: dropout)
  };
  std::int64_t step_of_sample(const SensorSpec& spec, std::int64_t n) const;
  void sample(std::size_t i, const SensorTruth& truth);

  std::vector<SensorSpec> specs_;
  double dt_s_;
  int num_rotors_;
  std::vector<Runtime> runtime_;
};

}  // namespace dronetwin
