#pragma once
// RosBridge: a VehicleLink (vehicle_link.hpp) on ROS 1 topics, in lockstep with its commands.
// Compiled as C++17: ROS Noetic's message headers do not build as C++20.
//
// The bridge owns simulated time. Every control period it publishes the vehicle at time t,
// stamped t, with /clock = t; then, in lockstep, it waits until a command stamped t (or later)
// arrives, applies it and steps the physics to t + period. So a controller node runs unchanged
// against the simulator (use_sim_time) and against hardware (wall time): it answers each state
// with a command carrying that state's stamp. Without lockstep the bridge paces itself at real
// time (times ~real_time_factor) and flies the latest command. Topics, message types and units:
// docs/ros.md.
//
// Trap: single-threaded; every callback runs on the thread that calls run().

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

#include "vehicle_link.hpp"

namespace dronetwin::ros_bridge {

struct BridgeSettings {
  LinkSettings link;
  bool lockstep = true;
  double command_timeout_s = 10.0;   ///< wall time to wait for a lockstep command; 0: forever
  double republish_period_s = 0.25;  ///< while waiting, the state is sent again this often
  int wait_for_subscribers = 0;      ///< start once odometry_measured has this many subscribers
  /// At most this many simulated s per wall s (0: no cap). main() defaults it to 1 without
  /// lockstep and to 0 with it (the controller sets the pace).
  double real_time_factor = 0.0;
  /// ROS time = simulated time + this. ROS 1 takes time 0 for "no clock yet": a node on simulated
  /// time (rosbag record) waits for a non-zero /clock and would miss the first states.
  double time_offset_s = 1.0;
  /// After the last state the node stays up this long (wall time): roscpp drops what it has not
  /// yet sent when the process exits, and a slow subscriber (a recorder) would lose the end.
  double linger_s = 2.0;
  std::string world_frame = "world";
  std::string body_frame = "base_link";
};

/// Exit codes of dronetwin_ros.
enum class BridgeExit : int {
  kFinished = 0,        ///< the experiment's duration flown
  kBadInput = 2,        ///< a bad experiment, parameter or controller file
  kVehicleFailed = 3,   ///< the simulator refused a step (collision, divergence)
  kCommandTimeout = 4,  ///< lockstep waited longer than command_timeout_s
  kShutdown = 5,        ///< ROS shut down (Ctrl-C, rosnode kill) before the end
};

class RosBridge {
 public:
  /// Throws std::invalid_argument naming the file or the parameter.
  RosBridge(const BridgeSettings& settings, ros::NodeHandle& nh);
  BridgeExit run();

 private:
  void on_rotor_speeds(const sensor_msgs::JointState::ConstPtr& msg);
  void on_ctbr(const geometry_msgs::TwistStamped::ConstPtr& msg);
  void on_pose(const geometry_msgs::PoseStamped::ConstPtr& msg);
  /// Lockstep drops commands stamped before the current state (answers to an earlier one).
  bool fresh(const ros::Time& stamp, const char* topic) const;
  /// The ROS time of the link's current state.
  ros::Time now() const;
  void accepted(const std::string& why_not, const char* topic);
  /// The state at the current time; with `sensors`, also the sensor readings delivered in the
  /// last period (once: a republished state leaves them out).
  void publish_state(bool sensors);
  void advertise_sensors(ros::NodeHandle& nh, std::uint32_t queue);
  void publish_sensor_reading(const LinkSensorReading& reading, const ros::Time& stamp);
  void publish_scene();
  BridgeExit wait_for_command();
  BridgeExit fly();
  void linger() const;

  BridgeSettings settings_;
  VehicleLink link_;
  std::uint64_t offset_ns_ = 0;
  bool answered_ = false;  ///< a fresh command for the current state was accepted

  ros::Publisher odometry_, odometry_measured_, imu_, rotor_speeds_, reference_, tf_, clock_,
      scene_;
  ros::Subscriber rotor_cmd_, ctbr_cmd_, pose_cmd_;
  // The experiment's sensors: per sensor its publishers (a GPS has two: position, velocity),
  // and /tf_static with their mountings.
  std::vector<LinkSensor> sensors_;
  std::vector<std::vector<ros::Publisher>> sensor_topics_;
  ros::Publisher tf_static_;
};

}  // namespace dronetwin::ros_bridge
