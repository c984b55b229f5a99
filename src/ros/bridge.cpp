#include "bridge.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

namespace dronetwin::ros_bridge {
namespace {

ros::Time to_time(std::uint64_t ns) {
  ros::Time t;
  t.fromNSec(ns);
  return t;
}

std::string stamp_text(const ros::Time& t) {
  char text[48];
  std::snprintf(text, sizeof text, "%u.%09u s", t.sec, t.nsec);
  return text;
}

void fill(geometry_msgs::Vector3& out, const std::array<double, 3>& v) {
  out.x = v[0];
  out.y = v[1];
  out.z = v[2];
}

void fill(geometry_msgs::Quaternion& out, const std::array<double, 4>& wxyz) {
  out.w = wxyz[0];
  out.x = wxyz[1];
  out.y = wxyz[2];
  out.z = wxyz[3];
}

nav_msgs::Odometry odometry(const LinkBodyState& s, const ros::Time& stamp,
                            const BridgeSettings& settings) {
  nav_msgs::Odometry m;
  m.header.stamp = stamp;
  m.header.frame_id = settings.world_frame;
  m.child_frame_id = settings.body_frame;
  m.pose.pose.position.x = s.position_m[0];
  m.pose.pose.position.y = s.position_m[1];
  m.pose.pose.position.z = s.position_m[2];
  fill(m.pose.pose.orientation, s.orientation_wxyz);
  fill(m.twist.twist.linear, s.velocity_B_m_s);
  fill(m.twist.twist.angular, s.rates_B_rad_s);
  return m;
}

visualization_msgs::Marker scene_marker(const LinkSceneItem& item, int id,
                                        const std::string& frame) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.id = id;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.text = item.name;
  m.color.a = 1.0F;
  if (item.kind == LinkSceneItem::Kind::kGate) {
    // The frame as a closed line through its bars' axes, as wide as the bars.
    m.ns = "gates";
    m.type = visualization_msgs::Marker::LINE_STRIP;
    m.scale.x = item.gate_bar_width_m;
    m.color.r = 1.0F;
    m.color.g = 0.5F;
    for (int i = 0; i <= 4; ++i) {
      const std::array<double, 3>& c = item.gate_bar_corners_m[static_cast<std::size_t>(i % 4)];
      geometry_msgs::Point p;
      p.x = c[0];
      p.y = c[1];
      p.z = c[2];
      m.points.push_back(p);
    }
    return m;
  }
  m.ns = "obstacles";
  m.type = item.kind == LinkSceneItem::Kind::kBox        ? visualization_msgs::Marker::CUBE
           : item.kind == LinkSceneItem::Kind::kCylinder ? visualization_msgs::Marker::CYLINDER
                                                         : visualization_msgs::Marker::SPHERE;
  m.pose.position.x = item.center_m[0];
  m.pose.position.y = item.center_m[1];
  m.pose.position.z = item.center_m[2];
  fill(m.scale, item.size_m);
  m.color.r = m.color.g = m.color.b = 0.6F;
  m.color.a = 0.8F;
  return m;
}

}  // namespace

RosBridge::RosBridge(const BridgeSettings& settings, ros::NodeHandle& nh)
    : settings_(settings), link_(settings.link) {
  const BridgeSettings& s = settings_;
  auto check = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(s.command_timeout_s >= 0.0 && std::isfinite(s.command_timeout_s),
        "~command_timeout_s: expected a finite value >= 0, got " +
            std::to_string(s.command_timeout_s));
  check(s.republish_period_s > 0.0 && std::isfinite(s.republish_period_s),
        "~republish_period_s: expected a finite value > 0, got " +
            std::to_string(s.republish_period_s));
  check(
      s.real_time_factor >= 0.0 && std::isfinite(s.real_time_factor),
      "~real_time_factor: expected a finite value >= 0, got " + std::to_string(s.real_time_factor));
  check(s.linger_s >= 0.0 && std::isfinite(s.linger_s),
        "~linger_s: expected a finite value >= 0, got " + std::to_string(s.linger_s));
  check(s.time_offset_s >= 0.0 && s.time_offset_s < 1e9,
        "~time_offset_s: expected a value in [0, 1e9) s, got " + std::to_string(s.time_offset_s));
  offset_ns_ = static_cast<std::uint64_t>(std::llround(s.time_offset_s * 1e9));
  check(s.wait_for_subscribers >= 0,
        "~wait_for_subscribers: expected >= 0, got " + std::to_string(s.wait_for_subscribers));

  // What a controller node needs to know about the airframe, on the parameter server.
  const LinkAirframe a = link_.airframe();
  ros::NodeHandle private_nh("~");
  private_nh.setParam("model", a.model);
  private_nh.setParam("mass_kg", a.mass_kg);
  private_nh.setParam("num_rotors", a.num_rotors);
  private_nh.setParam("gravity_m_s2", a.gravity_m_s2);
  private_nh.setParam("control_period_s", 1.0 / a.control_rate_hz);

  // Deep queues: a subscriber that falls behind for a moment (a recorder writing to disk) gets
  // every state late instead of losing some; the lockstep partner is never that far behind.
  constexpr std::uint32_t kQueue = 1000;
  odometry_ = nh.advertise<nav_msgs::Odometry>("odometry", kQueue);
  odometry_measured_ = nh.advertise<nav_msgs::Odometry>("odometry_measured", kQueue);
  imu_ = nh.advertise<sensor_msgs::Imu>("imu", kQueue);
  rotor_speeds_ = nh.advertise<std_msgs::Float64MultiArray>("rotor_speeds", kQueue);
  reference_ = nh.advertise<geometry_msgs::PoseStamped>("reference", kQueue);
  tf_ = nh.advertise<tf2_msgs::TFMessage>("/tf", kQueue);
  clock_ = nh.advertise<rosgraph_msgs::Clock>("/clock", kQueue);
  scene_ = nh.advertise<visualization_msgs::MarkerArray>("scene", 1, /*latch=*/true);
  // Without TCP_NODELAY every lockstep round trip waits on Nagle's algorithm (~40 ms).
  const ros::TransportHints no_delay = ros::TransportHints().tcpNoDelay();
  rotor_cmd_ = nh.subscribe("cmd/rotor_speeds", 10, &RosBridge::on_rotor_speeds, this, no_delay);
  ctbr_cmd_ = nh.subscribe("cmd/ctbr", 10, &RosBridge::on_ctbr, this, no_delay);
  if (link_.accepts_position_commands())
    pose_cmd_ = nh.subscribe("cmd/pose", 10, &RosBridge::on_pose, this, no_delay);
  advertise_sensors(nh, kQueue);
}

void RosBridge::advertise_sensors(ros::NodeHandle& nh, std::uint32_t queue) {
  sensors_ = link_.sensors();
  if (sensors_.empty()) return;
  tf2_msgs::TFMessage mounts;  // body -> <body>/<sensor>: where each sensor sits and looks
  for (const LinkSensor& s : sensors_) {
    const std::string topic = "sensors/" + s.name;
    std::vector<ros::Publisher> p;
    if (s.type == "imu") {
      p.push_back(nh.advertise<sensor_msgs::Imu>(topic, queue));
    } else if (s.type == "magnetometer") {
      p.push_back(nh.advertise<sensor_msgs::MagneticField>(topic, queue));
    } else if (s.type == "barometer") {
      p.push_back(nh.advertise<sensor_msgs::FluidPressure>(topic, queue));
    } else if (s.type == "gps") {
      p.push_back(nh.advertise<geometry_msgs::PointStamped>(topic + "/position", queue));
      p.push_back(nh.advertise<geometry_msgs::Vector3Stamped>(topic + "/velocity", queue));
    } else if (s.type == "motion_capture") {
      p.push_back(nh.advertise<geometry_msgs::PoseStamped>(topic, queue));
    } else if (s.type == "range_finder") {
      p.push_back(nh.advertise<sensor_msgs::Range>(topic, queue));
    } else if (s.type == "optical_flow") {
      p.push_back(nh.advertise<geometry_msgs::Vector3Stamped>(topic, queue));
    } else if (s.type == "rotor_speed") {
      p.push_back(nh.advertise<sensor_msgs::JointState>(topic, queue));
    } else {
      throw std::invalid_argument("sensor " + s.name + ": type " + s.type +
                                  " has no ROS message in this bridge");
    }
    sensor_topics_.push_back(std::move(p));
    geometry_msgs::TransformStamped mount;
    mount.header.stamp = now();
    mount.header.frame_id = settings_.body_frame;
    mount.child_frame_id = settings_.body_frame + "/" + s.name;
    fill(mount.transform.translation, s.position_B_m);
    fill(mount.transform.rotation, s.rotation_BS_wxyz);
    mounts.transforms.push_back(mount);
  }
  tf_static_ = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, /*latch=*/true);
  tf_static_.publish(mounts);
}

void RosBridge::publish_sensor_reading(const LinkSensorReading& reading, const ros::Time& stamp) {
  const LinkSensor& s = sensors_[static_cast<std::size_t>(reading.sensor)];
  std::vector<ros::Publisher>& topics = sensor_topics_[static_cast<std::size_t>(reading.sensor)];
  const auto& v = reading.values;  // the first reading.size, in the order of s.channels
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = settings_.body_frame + "/" + s.name;
  if (s.type == "imu") {  // fx fy fz (m/s^2) wx wy wz (rad/s), sensor frame
    sensor_msgs::Imu m;
    m.header = header;
    m.orientation_covariance[0] = -1.0;  // the message's "no orientation estimate"
    fill(m.linear_acceleration, {v[0], v[1], v[2]});
    fill(m.angular_velocity, {v[3], v[4], v[5]});
    topics[0].publish(m);
  } else if (s.type == "magnetometer") {  // bx by bz in uT; the message holds tesla
    sensor_msgs::MagneticField m;
    m.header = header;
    fill(m.magnetic_field, {v[0] * 1e-6, v[1] * 1e-6, v[2] * 1e-6});
    topics[0].publish(m);
  } else if (s.type == "barometer") {  // p in Pa
    sensor_msgs::FluidPressure m;
    m.header = header;
    m.fluid_pressure = v[0];
    topics[0].publish(m);
  } else if (s.type == "gps") {  // x y z (m) vx vy vz (m/s), world frame
    header.frame_id = settings_.world_frame;
    geometry_msgs::PointStamped position;
    position.header = header;
    position.point.x = v[0];
    position.point.y = v[1];
    position.point.z = v[2];
    topics[0].publish(position);
    geometry_msgs::Vector3Stamped velocity;
    velocity.header = header;
    fill(velocity.vector, {v[3], v[4], v[5]});
    topics[1].publish(velocity);
  } else if (s.type == "motion_capture") {  // x y z (m) qw qx qy qz, world frame
    geometry_msgs::PoseStamped m;
    m.header = header;
    m.header.frame_id = settings_.world_frame;
    m.pose.position.x = v[0];
    m.pose.position.y = v[1];
    m.pose.position.z = v[2];
    fill(m.pose.orientation, {v[3], v[4], v[5], v[6]});
    topics[0].publish(m);
  } else if (s.type == "range_finder") {  // d in m along sensor z; NaN: no return
    sensor_msgs::Range m;
    m.header = header;
    m.radiation_type = sensor_msgs::Range::INFRARED;
    m.field_of_view = 0.0F;  // a single ray
    m.min_range = static_cast<float>(s.min_range_m);
    m.max_range = static_cast<float>(s.max_range_m);
    m.range = static_cast<float>(v[0]);
    topics[0].publish(m);
  } else if (s.type == "optical_flow") {  // x y in rad/s, sensor frame; NaN: no reading
    geometry_msgs::Vector3Stamped m;
    m.header = header;
    fill(m.vector, {v[0], v[1], 0.0});
    topics[0].publish(m);
  } else if (s.type == "rotor_speed") {  // w0 .. w{N-1} in rad/s
    sensor_msgs::JointState m;
    m.header = header;
    for (int i = 0; i < reading.size; ++i) m.name.push_back("rotor_" + std::to_string(i));
    m.velocity.assign(v.begin(), v.begin() + reading.size);
    topics[0].publish(m);
  }
}

ros::Time RosBridge::now() const { return to_time(link_.stamp_ns() + offset_ns_); }

bool RosBridge::fresh(const ros::Time& stamp, const char* topic) const {
  if (!settings_.lockstep || stamp >= now()) return true;
  ROS_DEBUG("%s: dropped a command stamped %s, before the state at %s", topic,
            stamp_text(stamp).c_str(), stamp_text(now()).c_str());
  return false;
}

void RosBridge::accepted(const std::string& why_not, const char* topic) {
  if (why_not.empty()) {
    answered_ = true;
    return;
  }
  ROS_ERROR("%s: command refused: %s", topic, why_not.c_str());
}

void RosBridge::on_rotor_speeds(const sensor_msgs::JointState::ConstPtr& msg) {
  if (!fresh(msg->header.stamp, "cmd/rotor_speeds")) return;
  accepted(link_.command_rotor_speeds(msg->velocity), "cmd/rotor_speeds (velocity)");
}

void RosBridge::on_ctbr(const geometry_msgs::TwistStamped::ConstPtr& msg) {
  if (!fresh(msg->header.stamp, "cmd/ctbr")) return;
  const geometry_msgs::Twist& t = msg->twist;
  accepted(link_.command_ctbr(t.linear.z, {t.angular.x, t.angular.y, t.angular.z}),
           "cmd/ctbr (twist.linear.z, twist.angular)");
}

void RosBridge::on_pose(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  if (!fresh(msg->header.stamp, "cmd/pose")) return;
  const geometry_msgs::Pose& p = msg->pose;
  const geometry_msgs::Quaternion& q = p.orientation;
  const double norm2 = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
  if (!(norm2 > 1e-12) || !std::isfinite(norm2)) {
    ROS_ERROR(
        "cmd/pose: command refused: pose.orientation must be a finite non-zero "
        "quaternion");
    return;
  }
  // Heading of the body x axis: atan2 of R(1,0) and R(0,0) of the (normalised) quaternion.
  const double yaw_rad =
      std::atan2(2.0 * (q.w * q.z + q.x * q.y), norm2 - 2.0 * (q.y * q.y + q.z * q.z));
  accepted(link_.command_pose({p.position.x, p.position.y, p.position.z}, yaw_rad),
           "cmd/pose (pose)");
}

void RosBridge::publish_state(bool sensors) {
  const LinkSnapshot s = link_.snapshot();
  const ros::Time stamp = to_time(s.stamp_ns + offset_ns_);
  if (sensors) {
    for (const LinkSensorReading& r : s.sensor_readings)
      publish_sensor_reading(r, to_time(r.stamp_ns + offset_ns_));
  }
  rosgraph_msgs::Clock clock;
  clock.clock = stamp;
  clock_.publish(clock);
  odometry_.publish(odometry(s.state, stamp, settings_));
  odometry_measured_.publish(odometry(s.measured, stamp, settings_));

  sensor_msgs::Imu imu;  // ideal: true attitude, rates and specific force; covariances unknown
  imu.header.stamp = stamp;
  imu.header.frame_id = settings_.body_frame;
  fill(imu.orientation, s.state.orientation_wxyz);
  fill(imu.angular_velocity, s.state.rates_B_rad_s);
  fill(imu.linear_acceleration, s.specific_force_B_m_s2);
  imu_.publish(imu);

  std_msgs::Float64MultiArray speeds;
  speeds.data = s.rotor_speeds_rad_s;
  rotor_speeds_.publish(speeds);

  if (s.has_reference) {
    geometry_msgs::PoseStamped ref;
    ref.header.stamp = stamp;
    ref.header.frame_id = settings_.world_frame;
    ref.pose.position.x = s.reference_position_m[0];
    ref.pose.position.y = s.reference_position_m[1];
    ref.pose.position.z = s.reference_position_m[2];
    ref.pose.orientation.w = std::cos(0.5 * s.reference_yaw_rad);
    ref.pose.orientation.z = std::sin(0.5 * s.reference_yaw_rad);
    reference_.publish(ref);
  }

  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = settings_.world_frame;
  tf.child_frame_id = settings_.body_frame;
  tf.transform.translation.x = s.state.position_m[0];
  tf.transform.translation.y = s.state.position_m[1];
  tf.transform.translation.z = s.state.position_m[2];
  fill(tf.transform.rotation, s.state.orientation_wxyz);
  tf2_msgs::TFMessage tfs;
  tfs.transforms.push_back(tf);
  tf_.publish(tfs);
}

void RosBridge::publish_scene() {
  visualization_msgs::MarkerArray markers;
  const std::vector<LinkSceneItem> items = link_.scene();
  for (std::size_t i = 0; i < items.size(); ++i)
    markers.markers.push_back(scene_marker(items[i], static_cast<int>(i), settings_.world_frame));
  scene_.publish(markers);  // latched: late subscribers get it, an empty array when no scene
}

BridgeExit RosBridge::wait_for_command() {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto last_sent = start;
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  while (!answered_) {
    if (!ros::ok()) return BridgeExit::kShutdown;
    queue.callAvailable(ros::WallDuration(0.005));
    if (answered_) break;
    const auto wall_now = Clock::now();
    const double waited_s = std::chrono::duration<double>(wall_now - start).count();
    if (settings_.command_timeout_s > 0.0 && waited_s > settings_.command_timeout_s) {
      ROS_ERROR(
          "lockstep: no command on cmd/rotor_speeds, cmd/ctbr%s stamped %s or later "
          "within %g s (~command_timeout_s)",
          link_.accepts_position_commands() ? " or cmd/pose" : "", stamp_text(now()).c_str(),
          settings_.command_timeout_s);
      return BridgeExit::kCommandTimeout;
    }
    // A controller that subscribed after the state went out (or lost it) gets it again.
    if (std::chrono::duration<double>(wall_now - last_sent).count() >
        settings_.republish_period_s) {
      publish_state(false);  // the readings went out with the first
      last_sent = wall_now;
    }
  }
  return BridgeExit::kFinished;
}

BridgeExit RosBridge::run() {
  const BridgeExit exit = fly();
  if (exit != BridgeExit::kShutdown) linger();
  return exit;
}

void RosBridge::linger() const {
  const auto until = std::chrono::steady_clock::now() +
                     std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double>(settings_.linger_s));
  while (ros::ok() && std::chrono::steady_clock::now() < until)
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.01));
}

BridgeExit RosBridge::fly() {
  publish_scene();
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  // Until the first state goes out, /clock holds the start time: a node on simulated time (a
  // recorder) only starts once its clock is valid (non-zero: time_offset_s), and would drop the
  // first states otherwise.
  // After the subscribers are there it keeps going for one republish period, for the
  // connections of theirs that are still being made (a recorder's to the controller's commands).
  rosgraph_msgs::Clock start;
  start.clock = now();
  const auto wanted = static_cast<std::uint32_t>(settings_.wait_for_subscribers);
  std::chrono::steady_clock::time_point settled{};
  while (true) {
    if (!ros::ok()) return BridgeExit::kShutdown;
    clock_.publish(start);
    queue.callAvailable(ros::WallDuration(0.01));
    const auto wall_now = std::chrono::steady_clock::now();
    if (odometry_measured_.getNumSubscribers() < wanted) continue;
    if (settled == std::chrono::steady_clock::time_point{}) settled = wall_now;
    if (wanted == 0 ||
        std::chrono::duration<double>(wall_now - settled).count() >= settings_.republish_period_s)
      break;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  const std::uint64_t start_ns = link_.stamp_ns();
  while (true) {
    publish_state(true);
    if (link_.finished()) return BridgeExit::kFinished;
    answered_ = false;
    if (settings_.lockstep) {
      const BridgeExit waited = wait_for_command();
      if (waited != BridgeExit::kFinished) return waited;
    } else {
      if (!ros::ok()) return BridgeExit::kShutdown;
      queue.callAvailable();
    }
    if (settings_.real_time_factor > 0.0) {  // at most this fast, in either mode
      const double wall_s =
          1e-9 * static_cast<double>(link_.stamp_ns() - start_ns) / settings_.real_time_factor;
      std::this_thread::sleep_until(wall_start +
                                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(wall_s)));
    }
    const std::string failure = link_.advance();
    if (!failure.empty()) {
      publish_state(true);
      ROS_ERROR("%s", failure.c_str());
      return BridgeExit::kVehicleFailed;
    }
  }
}

}  // namespace dronetwin::ros_bridge
