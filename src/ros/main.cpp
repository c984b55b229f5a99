// dronetwin_ros: one experiment on ROS 1 topics, in lockstep with a controller node.
//
//   roscore &
//   rosparam set use_sim_time true
//   dronetwin_ros config/experiments/ros_hover.yaml __ns:=dronetwin
//   roslaunch config/ros/hover_ctbr.launch      (the same, with the example controller)
//
// Private parameters (~name; defaults in bridge.hpp): experiment (instead of the argument),
// lockstep, control_rate_hz, command_timeout_s, republish_period_s, wait_for_subscribers,
// real_time_factor, time_offset_s, linger_s, position_controller, world_frame, body_frame. Topics
// and exit codes: docs/ros.md.
#include <exception>
#include <iostream>
#include <stdexcept>
#include <string>

#include "bridge.hpp"

namespace {

using dronetwin::ros_bridge::BridgeExit;
using dronetwin::ros_bridge::BridgeSettings;

BridgeSettings read_settings(int argc, char** argv, const ros::NodeHandle& p) {
  BridgeSettings s;
  // ros::init has removed its own remapping arguments (name:=value) from argv.
  if (argc > 2) {
    throw std::invalid_argument("expected at most one argument (the experiment file), got " +
                                std::to_string(argc - 1));
  }
  if (argc == 2) s.link.experiment_path = argv[1];
  p.param("experiment", s.link.experiment_path, s.link.experiment_path);
  p.param("lockstep", s.lockstep, s.lockstep);
  p.param("control_rate_hz", s.link.control_rate_hz, s.link.control_rate_hz);
  p.param("command_timeout_s", s.command_timeout_s, s.command_timeout_s);
  p.param("republish_period_s", s.republish_period_s, s.republish_period_s);
  p.param("wait_for_subscribers", s.wait_for_subscribers, s.wait_for_subscribers);
  p.param("real_time_factor", s.real_time_factor, s.lockstep ? 0.0 : 1.0);
  p.param("time_offset_s", s.time_offset_s, s.time_offset_s);
  p.param("linger_s", s.linger_s, s.linger_s);
  p.param("position_controller", s.link.position_controller, s.link.position_controller);
  p.param("world_frame", s.world_frame, s.world_frame);
  p.param("body_frame", s.body_frame, s.body_frame);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "dronetwin_ros");
  ros::NodeHandle nh;
  const ros::NodeHandle private_nh("~");
  try {
    const BridgeSettings settings = read_settings(argc, argv, private_nh);
    dronetwin::ros_bridge::RosBridge bridge(settings, nh);
    const BridgeExit exit = bridge.run();
    if (exit == BridgeExit::kFinished) ROS_INFO("dronetwin_ros: experiment finished");
    return static_cast<int>(exit);
  } catch (const std::invalid_argument& err) {
    std::cerr << "dronetwin_ros: " << err.what() << "\n";
    return static_cast<int>(BridgeExit::kBadInput);
  } catch (const std::exception& err) {
    std::cerr << "dronetwin_ros: " << err.what() << "\n";
    return static_cast<int>(BridgeExit::kVehicleFailed);
  }
}
