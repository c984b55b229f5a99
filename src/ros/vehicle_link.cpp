#include "vehicle_link.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <variant>

#include <Eigen/Geometry>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/body_rate.hpp"
#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "dronetwin/world/collision.hpp"

namespace dronetwin::ros_bridge {

static_assert(kMaxLinkSensorValues >= kMaxSensorValues,
              "LinkSensorReading must hold the largest sensor reading");

namespace {

namespace si = state_index;

Eigen::Quaterniond attitude(const StateVector& x) {
  return Eigen::Quaterniond(x[si::kQuaternion], x[si::kQuaternion + 1], x[si::kQuaternion + 2],
                            x[si::kQuaternion + 3])
      .normalized();
}

std::array<double, 3> array_of(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

LinkBodyState body_state(const StateVector& x) {
  const Eigen::Quaterniond q = attitude(x);
  LinkBodyState s;
  s.position_m = array_of(x.segment<3>(si::kPosition));
  s.orientation_wxyz = {x[si::kQuaternion], x[si::kQuaternion + 1], x[si::kQuaternion + 2],
                        x[si::kQuaternion + 3]};
  // REP 105: Odometry's twist is in the child (body) frame, the state's velocity in the world.
  s.velocity_B_m_s = array_of(q.toRotationMatrix().transpose() * x.segment<3>(si::kVelocity));
  s.rates_B_rad_s = array_of(x.segment<3>(si::kAngularVelocity));
  return s;
}

enum class Mode { kInitial, kRotorSpeeds, kCtbr, kPose };

}  // namespace

struct VehicleLink::Impl {
  Experiment experiment;
  std::shared_ptr<const VehicleModel> model;
  std::unique_ptr<Simulator> sim;
  double control_rate_hz = 0.0;
  std::int64_t steps_per_period = 1;
  std::int64_t total_steps = 0;
  Mode mode = Mode::kInitial;
  RotorVector rotor_command_rad_s;
  std::unique_ptr<BodyRateController> rates;
  std::unique_ptr<ControllerBase> position;
  ReferencePoint setpoint{};
  std::string failure;
  // The experiment's sensors, sampled at every physics step as `dronetwin run` samples them,
  // and what they delivered in the current period.
  std::optional<SensorSuite> sensors;
  StateVector previous_state;
  std::vector<LinkSensorReading> delivered;

  void sense() {
    if (!sensors) return;
    sensors->update(sim->step_count(), make_sensor_truth(*sim, previous_state));
    previous_state = sim->state();
    for (int i = 0; i < sensors->size(); ++i) {
      if (!sensors->fresh(i)) continue;
      const SensorReading& reading = sensors->latest(i);
      LinkSensorReading out;
      out.sensor = i;
      out.stamp_ns = static_cast<std::uint64_t>(std::llround(reading.stamp_s * 1e9));
      out.size = reading.size;
      std::copy(reading.values.begin(), reading.values.begin() + reading.size, out.values.begin());
      delivered.push_back(out);  // within the capacity reserved for a period: no allocation
    }
  }

  RotorVector actuation() {
    if (mode == Mode::kInitial || mode == Mode::kRotorSpeeds) return rotor_command_rad_s;
    ControllerBase& c = mode == Mode::kCtbr ? static_cast<ControllerBase&>(*rates) : *position;
    ControlInput in;
    in.time_s = sim->time_s();
    in.state = sim->measured_state();
    if (c.uses_state_derivative()) in.state_derivative = sim->measured_state_derivative();
    in.reference = setpoint;
    return c.calculate_actuator_cmd(in);
  }
};

VehicleLink::VehicleLink(const LinkSettings& settings) : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  require(!settings.experiment_path.empty(), "no experiment file given");
  require(settings.control_rate_hz >= 0.0 && std::isfinite(settings.control_rate_hz),
          "control_rate_hz: expected a finite value >= 0 (0: the experiment's), got ",
          settings.control_rate_hz);
  r.experiment = load_experiment(settings.experiment_path);
  const Experiment& e = r.experiment;
  r.model = std::make_shared<const VehicleModel>(load_vehicle_model(e.model_path));
  check_against_model(e, *r.model);
  r.sim = std::make_unique<Simulator>(r.model, e.sim_config());
  RotorVector initial_speeds;
  try {
    initial_speeds = e.initial_state.rotor_speeds.resolve(*r.model, e.gravity_magnitude());
    r.sim->reset(e.initial_state.state(), initial_speeds);
  } catch (const InvalidArgument& err) {
    throw InvalidArgument(e.source + ": initial_state: " + err.what());
  }
  if (e.scene != nullptr) {
    const SceneContact at_start =
        find_scene_contact(*e.scene, r.model->collision_shape(), r.sim->state(), r.sim->state());
    require(!at_start, e.source, ": initial_state: the vehicle starts inside ",
            describe_contact(*e.scene, at_start), " of the scene ", e.scene_path);
    r.sim->set_scene(e.scene);
  }
  r.rotor_command_rad_s = initial_speeds;
  r.total_steps = e.num_steps();
  if (!e.sensors.empty()) {
    try {
      r.sensors.emplace(e.sensors, e.sim.dt_s, r.model->num_rotors(), e.sim.seed);
    } catch (const InvalidArgument& err) {
      throw InvalidArgument(e.source + ": " + err.what());
    }
    r.previous_state = r.sim->state();
    r.sense();  // the samples of step 0
  }
  r.setpoint.position_m = e.initial_state.state().segment<3>(si::kPosition);

  // One period: the experiment's control rate, so that a controller node sees the states the
  // experiment's own controller would.
  r.control_rate_hz = settings.control_rate_hz;
  if (r.control_rate_hz == 0.0) {
    const auto* loop = std::get_if<ControllerLoopInput>(&e.input);
    r.control_rate_hz = loop != nullptr ? loop->control_rate_hz : 100.0;
  }
  const double ratio = 1.0 / (r.control_rate_hz * e.sim.dt_s);
  r.steps_per_period = std::llround(ratio);
  require(r.steps_per_period >= 1 &&
              std::abs(ratio - static_cast<double>(r.steps_per_period)) < 1e-9 * ratio,
          "control rate ", r.control_rate_hz, " Hz: expected a divisor of the physics rate ",
          1.0 / e.sim.dt_s, " Hz of ", e.source);

  // A sensor delivers at most one reading per physics step (its rate is bounded by the physics
  // rate and its latency is fixed).
  if (r.sensors)
    r.delivered.reserve(static_cast<std::size_t>(r.steps_per_period) *
                        static_cast<std::size_t>(r.sensors->size()));

  r.rates = std::make_unique<BodyRateController>(r.model, BodyRateGains{});
  if (!settings.position_controller.empty()) {
    r.position = load_controller(settings.position_controller, r.model, 1.0 / e.sim.dt_s);
    r.position->reset();
  }
}

VehicleLink::~VehicleLink() = default;

LinkAirframe VehicleLink::airframe() const {
  const Impl& r = *impl_;
  return {r.model->name(), r.model->mass_kg(), r.model->num_rotors(),
          r.experiment.gravity_magnitude(), r.control_rate_hz};
}

std::vector<LinkSensor> VehicleLink::sensors() const {
  const Impl& r = *impl_;
  std::vector<LinkSensor> out;
  if (!r.sensors) return out;
  for (const SensorSpec& spec : r.experiment.sensors) {
    LinkSensor s;
    s.name = spec.name;
    s.type = std::string(spec.type_name());
    for (const SensorChannel& c : sensor_channels(spec, r.model->num_rotors()))
      s.channels.push_back(c.suffix);
    s.position_B_m = array_of(spec.mounting.position_B_m);
    const Vec4& q = spec.mounting.rotation_BS_wxyz;
    s.rotation_BS_wxyz = {q[0], q[1], q[2], q[3]};
    if (const auto* range = std::get_if<RangeFinderParameters>(&spec.parameters)) {
      s.min_range_m = range->min_range_m;
      s.max_range_m = range->max_range_m;
    }
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<LinkSceneItem> VehicleLink::scene() const {
  std::vector<LinkSceneItem> items;
  const Track* scene = impl_->experiment.scene.get();
  if (scene == nullptr) return items;
  for (const Gate& g : scene->gates) {
    LinkSceneItem item;
    item.kind = LinkSceneItem::Kind::kGate;
    item.name = g.name;
    item.center_m = array_of(g.center_m);
    const std::array<Vec3, 4> corners = g.bar_corners();
    for (std::size_t i = 0; i < corners.size(); ++i)
      item.gate_bar_corners_m[i] = array_of(corners[i]);
    item.gate_bar_width_m = g.frame_width_m;
    items.push_back(item);
  }
  for (const Obstacle& o : scene->obstacles) {
    LinkSceneItem item;
    item.kind = o.shape == Obstacle::Shape::kBox        ? LinkSceneItem::Kind::kBox
                : o.shape == Obstacle::Shape::kCylinder ? LinkSceneItem::Kind::kCylinder
                                                        : LinkSceneItem::Kind::kSphere;
    item.name = o.name;
    item.center_m = array_of(o.center_m);
    item.size_m = array_of(2.0 * o.half_size_m);  // half extents / radii and half height
    items.push_back(item);
  }
  return items;
}

std::uint64_t VehicleLink::stamp_ns() const {
  // From the step count, not the accumulated time: exact to the nanosecond at every period.
  const double t_s = static_cast<double>(impl_->sim->step_count()) * impl_->experiment.sim.dt_s;
  return static_cast<std::uint64_t>(std::llround(t_s * 1e9));
}

bool VehicleLink::finished() const { return impl_->sim->step_count() >= impl_->total_steps; }

bool VehicleLink::accepts_position_commands() const { return impl_->position != nullptr; }

LinkSnapshot VehicleLink::snapshot() const {
  const Impl& r = *impl_;
  const Simulator& sim = *r.sim;
  LinkSnapshot s;
  s.stamp_ns = stamp_ns();
  s.state = body_state(sim.state());
  s.measured = body_state(sim.measured_state());
  const Vec3 specific_force_W =
      sim.state_derivative().segment<3>(si::kVelocity) - sim.config().environment.gravity_W_m_s2;
  s.specific_force_B_m_s2 =
      array_of(attitude(sim.state()).toRotationMatrix().transpose() * specific_force_W);
  const RotorVector& w = sim.rotor_speeds_rad_s();
  s.rotor_speeds_rad_s.assign(w.data(), w.data() + w.size());
  if (const auto* loop = std::get_if<ControllerLoopInput>(&r.experiment.input)) {
    const ReferencePoint p = loop->reference->at(sim.time_s());
    s.has_reference = true;
    s.reference_position_m = array_of(p.position_m);
    s.reference_yaw_rad = p.yaw_rad;
  }
  s.sensor_readings = r.delivered;
  return s;
}

std::string VehicleLink::command_rotor_speeds(const std::vector<double>& speeds_rad_s) {
  Impl& r = *impl_;
  const int n = r.model->num_rotors();
  if (static_cast<int>(speeds_rad_s.size()) != n) {
    return detail::concat(speeds_rad_s.size(), " rotor speeds, expected ", n, " (one per rotor of ",
                          r.model->name(), ")");
  }
  RotorVector w(n);
  for (int i = 0; i < n; ++i) {
    const double v = speeds_rad_s[static_cast<std::size_t>(i)];
    if (!std::isfinite(v) || v < 0.0)
      return detail::concat("rotor speed [", i, "] = ", v, ", expected a finite value >= 0 rad/s");
    w[i] = v;
  }
  r.rotor_command_rad_s = w;
  r.mode = Mode::kRotorSpeeds;
  return {};
}

std::string VehicleLink::command_ctbr(double thrust_N, const std::array<double, 3>& rates) {
  Impl& r = *impl_;
  const Vec3 w(rates[0], rates[1], rates[2]);
  if (!std::isfinite(thrust_N) || thrust_N < 0.0 || !w.allFinite()) {
    return detail::concat("expected a finite thrust >= 0 N and finite body rates, got thrust ",
                          thrust_N, " N, rates (", w.x(), ", ", w.y(), ", ", w.z(), ") rad/s");
  }
  r.rates->set_command(thrust_N, w);
  r.mode = Mode::kCtbr;
  return {};
}

std::string VehicleLink::command_pose(const std::array<double, 3>& position_m, double yaw_rad) {
  Impl& r = *impl_;
  if (!r.position) return "no position controller (the bridge's ~position_controller is empty)";
  const Vec3 p(position_m[0], position_m[1], position_m[2]);
  if (!p.allFinite() || !std::isfinite(yaw_rad))
    return detail::concat("expected a finite position and yaw, got (", p.x(), ", ", p.y(), ", ",
                          p.z(), ") m, yaw ", yaw_rad, " rad");
  r.setpoint = ReferencePoint{};
  r.setpoint.position_m = p;
  r.setpoint.yaw_rad = yaw_rad;
  r.mode = Mode::kPose;
  return {};
}

std::string VehicleLink::advance() {
  Impl& r = *impl_;
  if (!r.failure.empty()) return r.failure;
  Simulator& sim = *r.sim;
  const std::int64_t steps = std::min(r.steps_per_period, r.total_steps - sim.step_count());
  r.delivered.clear();
  for (std::int64_t k = 0; k < steps; ++k) {
    try {
      sim.set_rotor_speed_reference(r.actuation());
    } catch (const std::exception& err) {
      r.failure =
          detail::concat("t = ", sim.time_s(), " s: the command cannot be flown: ", err.what());
      return r.failure;
    }
    if (!sim.step().ok()) {
      r.failure = detail::concat("t = ", sim.time_s(), " s: ", sim.failure_message());
      return r.failure;
    }
    r.sense();
  }
  return {};
}

}  // namespace dronetwin::ros_bridge
