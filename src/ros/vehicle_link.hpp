#pragma once
// VehicleLink: the simulator side of the ROS 1 bridge, with no ROS in it.
//
// ROS Noetic's message headers do not compile as C++20 (their allocators use
// std::allocator<void>::rebind, removed in C++20), and dronetwin needs C++20. So the bridge is
// two halves: this one (C++20, dronetwin inside, plain C++17 types in its interface) owns the
// experiment's simulator and the command logic; bridge.cpp (C++17, ROS inside) turns its
// snapshots into messages and messages into its commands. It is also what the unit tests drive
// without a ROS master (tests/ros/vehicle_link_test.cpp).
//
//   VehicleLink link({"config/experiments/ros_hover.yaml"});
//   while (!link.finished()) {
//     const LinkSnapshot s = link.snapshot();          // publish it
//     link.command_ctbr(thrust_N, rates);              // a controller's answer
//     if (std::string why = link.advance(); !why.empty()) break;   // one control period
//   }
//
// Commands: rotor speed references (flown as given), collective thrust + body rates (flown by
// the body-rate controller, control/body_rate.hpp, every physics step) and a position + yaw
// setpoint (flown by the controller file of LinkSettings::position_controller every physics
// step). The latest accepted command is flown until another is accepted; before any, the
// experiment's initial rotor speeds. A command that cannot be flown is refused with the reason
// and the previous one stays.
//
// Trap: one thread at a time (the simulator inside says so if two try).

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dronetwin::ros_bridge {

struct LinkSettings {
  std::string experiment_path;
  /// Controller file for position commands; empty: the link refuses them.
  std::string position_controller;
  /// Period of snapshots and commands: 0 takes the experiment's control_rate_hz (a controller
  /// input), else 100 Hz. Must divide the physics rate.
  double control_rate_hz = 0.0;
};

/// A rigid-body state the way ROS's Odometry carries it (REP 103/105): pose in the world frame,
/// twist in the body frame.
struct LinkBodyState {
  std::array<double, 3> position_m{};
  std::array<double, 4> orientation_wxyz{1.0, 0.0, 0.0, 0.0};
  std::array<double, 3> velocity_B_m_s{};
  std::array<double, 3> rates_B_rad_s{};
};

/// A sensor of the experiment's `sensors:` list, as the bridge publishes it (docs/sensors.md).
struct LinkSensor {
  std::string name;
  std::string type;                      ///< "imu", "magnetometer", ... (the YAML type names)
  std::vector<std::string> channels;     ///< its values' suffixes, in reading order (log columns)
  std::array<double, 3> position_B_m{};  ///< mounting: origin in the body frame
  std::array<double, 4> rotation_BS_wxyz{1.0, 0.0, 0.0, 0.0};  ///< sensor frame to body frame
  double min_range_m = 0.0, max_range_m = 0.0;                 ///< range finder: its limits
};

/// Most values in one reading (a rotor-speed sensor's: one per rotor, at most 8); vehicle_link.cpp
/// checks it against the sensor models' own bound.
inline constexpr int kMaxLinkSensorValues = 8;

/// One reading a sensor delivered (after its latency), as the run log's `<name>_*` columns hold it.
/// Fixed size, so that collecting the readings of a physics step allocates nothing.
struct LinkSensorReading {
  int sensor = 0;              ///< index in VehicleLink::sensors()
  std::uint64_t stamp_ns = 0;  ///< simulated time the sample was taken (before the latency)
  int size = 0;                ///< values in use: LinkSensor::channels.size()
  /// The first `size`, in the order of LinkSensor::channels, the log's units.
  std::array<double, kMaxLinkSensorValues> values{};
};

struct LinkSnapshot {
  std::uint64_t stamp_ns = 0;  ///< simulated time, exact: step count x physics dt
  LinkBodyState state;         ///< true state
  LinkBodyState measured;      ///< measured (noisy when the experiment's noise is on)
  /// What an ideal accelerometer at the centre of mass reads: R^T (a_W - g_W), m/s^2.
  std::array<double, 3> specific_force_B_m_s2{};
  std::vector<double> rotor_speeds_rad_s;
  bool has_reference = false;  ///< the experiment's reference (controller inputs)
  std::array<double, 3> reference_position_m{};
  double reference_yaw_rad = 0.0;
  /// The readings the experiment's sensors delivered in the last period (at t = 0: those of
  /// step 0), in delivery order.
  std::vector<LinkSensorReading> sensor_readings;
};

struct LinkSceneItem {
  enum class Kind { kGate, kBox, kCylinder, kSphere };
  Kind kind = Kind::kBox;
  std::string name;
  std::array<double, 3> center_m{};
  std::array<double, 3> size_m{};  ///< full extents (box), (2R, 2R, height), (2r, 2r, 2r)
  std::array<std::array<double, 3>, 4> gate_bar_corners_m{};  ///< gates: the frame's corners
  double gate_bar_width_m = 0.0;
};

struct LinkAirframe {
  std::string model;
  double mass_kg = 0.0;
  int num_rotors = 0;
  double gravity_m_s2 = 0.0;
  double control_rate_hz = 0.0;
};

class VehicleLink {
 public:
  /// Loads the experiment, its model and scene, and the position controller. Throws
  /// std::invalid_argument (dronetwin::InvalidArgument) naming the file and the field.
  explicit VehicleLink(const LinkSettings& settings);
  ~VehicleLink();
  VehicleLink(const VehicleLink&) = delete;
  VehicleLink& operator=(const VehicleLink&) = delete;

  LinkAirframe airframe() const;
  std::vector<LinkSceneItem> scene() const;
  /// The experiment's sensors (empty without `sensors:`).
  std::vector<LinkSensor> sensors() const;
  LinkSnapshot snapshot() const;
  std::uint64_t stamp_ns() const;
  /// The experiment's duration has been flown.
  bool finished() const;
  bool accepts_position_commands() const;

  /// Each returns "" when the command is accepted, else why not (and the previous one stays).
  std::string command_rotor_speeds(const std::vector<double>& speeds_rad_s);
  std::string command_ctbr(double thrust_N, const std::array<double, 3>& rates_B_rad_s);
  std::string command_pose(const std::array<double, 3>& position_m, double yaw_rad);

  /// Steps one control period (less at the end of the experiment). Returns "" or, when the
  /// simulator refused a step (collision, divergence) or the command cannot be flown, why; the
  /// link is then failed and advance() returns the same message again.
  std::string advance();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dronetwin::ros_bridge
