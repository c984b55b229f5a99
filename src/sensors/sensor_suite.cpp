#include "dronetwin/sensors/sensor_suite.hpp"

#include <cmath>
#include <set>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sensors/sample_schedule.hpp"

namespace dronetwin {

// ---- defaults -----------------------------------------------------------------------------------

namespace {

SensorSpec make(std::string name, double rate_hz, double latency_s, Mounting mounting,
                SensorParameters parameters) {
  SensorSpec s;
  s.name = std::move(name);
  s.rate_hz = rate_hz;
  s.latency_s = latency_s;
  s.mounting = mounting;
  s.parameters = parameters;
  return s;
}

}  // namespace

SensorSpec SensorSpec::imu(std::string name) {
  return make(std::move(name), 1000.0, 0.0, {}, ImuParameters{});
}
SensorSpec SensorSpec::magnetometer(std::string name) {
  return make(std::move(name), 100.0, 0.0, {}, MagnetometerParameters{});
}
SensorSpec SensorSpec::barometer(std::string name) {
  return make(std::move(name), 50.0, 0.0, {}, BarometerParameters{});
}
SensorSpec SensorSpec::gps(std::string name) {
  return make(std::move(name), 10.0, 0.1, {}, GpsParameters{});
}
SensorSpec SensorSpec::motion_capture(std::string name) {
  return make(std::move(name), 100.0, 0.005, {}, MotionCaptureParameters{});
}
SensorSpec SensorSpec::range_finder(std::string name) {
  return make(std::move(name), 50.0, 0.0, Mounting::looking_down(), RangeFinderParameters{});
}
SensorSpec SensorSpec::optical_flow(std::string name) {
  return make(std::move(name), 100.0, 0.0, Mounting::looking_down(), OpticalFlowParameters{});
}
SensorSpec SensorSpec::rotor_speed(std::string name) {
  return make(std::move(name), 200.0, 0.0, {}, RotorSpeedSensorParameters{});
}

SensorSpec SensorSpec::defaults(std::string_view type, std::string name) {
  if (type == "imu") return imu(std::move(name));
  if (type == "magnetometer") return magnetometer(std::move(name));
  if (type == "barometer") return barometer(std::move(name));
  if (type == "gps") return gps(std::move(name));
  if (type == "motion_capture") return motion_capture(std::move(name));
  if (type == "range_finder") return range_finder(std::move(name));
  if (type == "optical_flow") return optical_flow(std::move(name));
  if (type == "rotor_speed") return rotor_speed(std::move(name));
  throw InvalidArgument(detail::concat("unknown sensor type '", type,
                                       "' (valid: imu, magnetometer, barometer, gps, "
                                       "motion_capture, range_finder, optical_flow, rotor_speed)"));
}

// ---- channels -----------------------------------------------------------------------------------

namespace {

struct ChannelList {
  std::vector<SensorChannel> c;
  void add(std::string s, std::string u, std::string m) {
    c.push_back({std::move(s), std::move(u), std::move(m)});
  }
  void xyz(const std::string& prefix, const std::string& unit, const std::string& meaning) {
    for (const char* a : {"x", "y", "z"})
      add(detail::concat(prefix, a), unit, detail::concat(meaning, ", ", a, " axis"));
  }
};

}  // namespace

std::vector<SensorChannel> sensor_channels(const SensorSpec& spec, int num_rotors) {
  ChannelList l;
  switch (spec.parameters.index()) {
    case 0:  // imu
      l.xyz("f", "m/s^2", "specific force, sensor frame");
      l.xyz("w", "rad/s", "angular rate, sensor frame");
      break;
    case 1:  // magnetometer
      l.xyz("b", "uT", "magnetic field, sensor frame");
      break;
    case 2:  // barometer
      l.add("p", "Pa", "static pressure");
      break;
    case 3:  // gps
      l.xyz("", "m", "antenna position, world frame");
      l.xyz("v", "m/s", "antenna velocity, world frame");
      break;
    case 4:  // motion capture
      l.xyz("", "m", "tracked frame position, world frame");
      for (const char* a : {"qw", "qx", "qy", "qz"})
        l.add(a, "1", detail::concat("tracked frame attitude q_WS, component ", a + 1));
      break;
    case 5:  // range finder
      l.add("d", "m", "distance along the sensor z axis (NaN: no return)");
      break;
    case 6:  // optical flow
      l.add("x", "rad/s", "image flow at the principal point along sensor x (NaN: no reading)");
      l.add("y", "rad/s", "image flow at the principal point along sensor y (NaN: no reading)");
      break;
    default:  // rotor speed
      for (int i = 0; i < num_rotors; ++i)
        l.add(detail::concat("w", i), "rad/s", detail::concat("speed of rotor ", i));
      break;
  }
  return l.c;
}

int sensor_channel_index(const SensorSpec& spec, int num_rotors, std::string_view suffix) {
  const std::vector<SensorChannel> channels = sensor_channels(spec, num_rotors);
  for (std::size_t i = 0; i < channels.size(); ++i)
    if (channels[i].suffix == suffix) return static_cast<int>(i);
  return -1;
}

// ---- validation ---------------------------------------------------------------------------------

namespace {

void need(bool ok, const std::string& field, const char* expected, double got) {
  if (!ok) throw InvalidArgument(detail::concat(field, ": expected ", expected, ", got ", got));
}
void non_negative(double v, const std::string& field) {
  need(std::isfinite(v) && v >= 0.0, field, "a finite number >= 0", v);
}
void positive(double v, const std::string& field) {
  need(std::isfinite(v) && v > 0.0, field, "a finite number > 0", v);
}
void non_negative3(const Vec3& v, const std::string& field) {
  for (int i = 0; i < 3; ++i) non_negative(v[i], detail::concat(field, "[", i, "]"));
}
void finite3(const Vec3& v, const std::string& field) {
  for (int i = 0; i < 3; ++i)
    need(std::isfinite(v[i]), detail::concat(field, "[", i, "]"), "a finite number", v[i]);
}

void check_triad(const TriadNoise& n, const std::string& p) {
  non_negative(n.noise_density, detail::concat(p, ".noise_density"));
  non_negative(n.bias_random_walk, detail::concat(p, ".bias_random_walk"));
  non_negative(n.bias_instability, detail::concat(p, ".bias_instability"));
  positive(n.bias_correlation_time_s, detail::concat(p, ".bias_correlation_time_s"));
  non_negative(n.turn_on_bias, detail::concat(p, ".turn_on_bias"));
  non_negative(n.range, detail::concat(p, ".range"));
}

/// faults[j]: a window that starts at a finite time >= 0 and ends after it; a bias step on a
/// channel the sensor has, by a finite amount; a dropout without either.
void check_faults(const SensorSpec& s, double physics_dt_s) {
  if (s.faults.size() > kMaxSensorFaults)
    throw InvalidArgument(detail::concat("faults: expected at most ", kMaxSensorFaults,
                                         " faults on one sensor, got ", s.faults.size()));
  for (std::size_t j = 0; j < s.faults.size(); ++j) {
    const SensorFault& f = s.faults[j];
    const std::string at = detail::concat("faults[", j, "].");
    non_negative(f.start_s, at + "start_s");
    need(f.end_s == f.end_s && f.end_s >= f.start_s + physics_dt_s, at + "end_s",
         "a time at least one physics step after start_s (or none: the fault lasts)", f.end_s);
    if (f.kind == SensorFaultKind::kDropout) {
      if (!f.channel.empty() || f.value != 0.0)
        throw InvalidArgument(detail::concat(
            at, "channel: a dropout loses whole samples and has no channel or value, got '",
            f.channel, "' and ", f.value));
      continue;
    }
    need(std::isfinite(f.value), at + "value", "a finite number", f.value);
    if (sensor_channel_index(s, kMaxRotors, f.channel) < 0) {
      // Rotor speeds: the first four channels show the pattern (one per rotor).
      const bool per_rotor = std::holds_alternative<RotorSpeedSensorParameters>(s.parameters);
      std::string names;
      for (const SensorChannel& c : sensor_channels(s, per_rotor ? 4 : 1))
        names += detail::concat(names.empty() ? "" : ", ", c.suffix);
      throw InvalidArgument(detail::concat(at, "channel: expected a channel of a ", s.type_name(),
                                           " (", names, per_rotor ? ", ... one per rotor" : "",
                                           "), got '", f.channel, "'"));
    }
  }
}

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 32 || !(s[0] >= 'a' && s[0] <= 'z')) return false;
  for (const char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

}  // namespace

void validate(const SensorSpec& s, double physics_dt_s) {
  if (!valid_name(s.name))
    throw InvalidArgument(detail::concat(
        "name: expected 1-32 lower-case letters, digits or '_' starting with a letter (it names "
        "log columns), got '",
        s.name, "'"));
  positive(s.rate_hz, "rate_hz");
  if (s.rate_hz * physics_dt_s > 1.0 + 1e-9)
    throw InvalidArgument(
        detail::concat("rate_hz: ", s.rate_hz, " Hz is faster than the physics step (",
                       1.0 / physics_dt_s, " Hz); a sensor samples at most once per step"));
  non_negative(s.latency_s, "latency_s");
  need(s.latency_s <= 10.0, "latency_s", "at most 10 s", s.latency_s);
  finite3(s.mounting.position_B_m, "mounting.position_m");
  const double qn = s.mounting.rotation_BS_wxyz.norm();
  need(std::isfinite(qn) && std::abs(qn - 1.0) < 1e-9, "mounting.rotation", "a unit quaternion",
       qn);
  std::visit(
      [](const auto& p) {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, ImuParameters>) {
          check_triad(p.gyro, "gyro");
          check_triad(p.accel, "accel");
        } else if constexpr (std::is_same_v<P, MagnetometerParameters>) {
          finite3(p.field_W_uT, "field_uT");
          non_negative(p.noise_uT, "noise_uT");
          finite3(p.hard_iron_uT, "hard_iron_uT");
        } else if constexpr (std::is_same_v<P, BarometerParameters>) {
          non_negative(p.noise_Pa, "noise_Pa");
          non_negative(p.drift_Pa_per_sqrt_s, "drift_Pa_per_sqrt_s");
          need(std::isfinite(p.offset_Pa), "offset_Pa", "a finite number", p.offset_Pa);
          need(std::isfinite(p.origin_altitude_m) && p.origin_altitude_m >= -500.0 &&
                   p.origin_altitude_m <= 9000.0,
               "origin_altitude_m", "-500 .. 9000 m (the ISA troposphere, with room to fly)",
               p.origin_altitude_m);
        } else if constexpr (std::is_same_v<P, GpsParameters>) {
          non_negative3(p.position_noise_m, "position_noise_m");
          non_negative3(p.position_error_m, "position_error_m");
          positive(p.position_error_time_s, "position_error_time_s");
          non_negative3(p.velocity_noise_m_s, "velocity_noise_m_s");
        } else if constexpr (std::is_same_v<P, MotionCaptureParameters>) {
          non_negative(p.position_noise_m, "position_noise_m");
          non_negative(p.attitude_noise_rad, "attitude_noise_rad");
        } else if constexpr (std::is_same_v<P, RangeFinderParameters>) {
          non_negative(p.min_range_m, "min_range_m");
          positive(p.max_range_m, "max_range_m");
          need(p.max_range_m > p.min_range_m, "max_range_m", "a number > min_range_m",
               p.max_range_m);
          non_negative(p.noise_m, "noise_m");
          non_negative(p.noise_fraction, "noise_fraction");
          need(std::isfinite(p.dropout_probability) && p.dropout_probability >= 0.0 &&
                   p.dropout_probability <= 1.0,
               "dropout_probability", "a probability in [0, 1]", p.dropout_probability);
        } else if constexpr (std::is_same_v<P, OpticalFlowParameters>) {
          non_negative(p.noise_rad_s, "noise_rad_s");
          non_negative(p.min_distance_m, "min_distance_m");
          positive(p.max_distance_m, "max_distance_m");
          need(p.max_distance_m > p.min_distance_m, "max_distance_m", "a number > min_distance_m",
               p.max_distance_m);
        } else {
          non_negative(p.noise_rad_s, "noise_rad_s");
        }
      },
      s.parameters);
  check_faults(s, physics_dt_s);
}

// ---- the suite ----------------------------------------------------------------------------------

SensorSuite::SensorSuite(std::vector<SensorSpec> specs, double physics_dt_s, int num_rotors,
                         std::uint64_t seed)
    : specs_(std::move(specs)), dt_s_(physics_dt_s), num_rotors_(num_rotors) {
  require(std::isfinite(physics_dt_s) && physics_dt_s > 0.0,
          "SensorSuite: physics_dt_s: expected a number > 0, got ", physics_dt_s);
  require(num_rotors >= 1 && num_rotors <= kMaxRotors, "SensorSuite: num_rotors: expected 1 .. ",
          kMaxRotors, ", got ", num_rotors);
  std::set<std::string> names;
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const SensorSpec& s = specs_[i];
    const std::string where = detail::concat("sensors[", i, "] (", s.name, "): ");
    try {
      validate(s, physics_dt_s);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(where + e.what());
    }
    require(names.insert(s.name).second, where, "name: '", s.name,
            "' is already the name of another sensor (names label log columns)");
  }
  runtime_.resize(specs_.size());
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    // Samples in flight: those taken within one latency, plus the one delivered this step.
    const double in_flight = std::ceil(specs_[i].latency_s * specs_[i].rate_hz + 1e-9);
    runtime_[i].pending.resize(static_cast<std::size_t>(in_flight) + 2);
    runtime_[i].size = static_cast<int>(sensor_channels(specs_[i], num_rotors_).size());
    for (std::size_t j = 0; j < specs_[i].faults.size(); ++j) {
      const SensorFault& f = specs_[i].faults[j];
      const int channel = f.kind == SensorFaultKind::kBiasStep
                              ? sensor_channel_index(specs_[i], num_rotors_, f.channel)
                              : -1;
      require(f.kind != SensorFaultKind::kBiasStep || channel >= 0, "sensors[", i, "] (",
              specs_[i].name, "): faults[", j, "].channel: '", f.channel, "' is not a channel of ",
              num_rotors_, " rotors (", runtime_[i].size, " channels: w0 .. w",
              runtime_[i].size - 1, ")");
      runtime_[i].fault_channel.push_back(channel);
    }
  }
  reset(seed);
}

std::int64_t SensorSuite::step_of_sample(const SensorSpec& spec, std::int64_t n) const {
  return dronetwin::step_of_sample(n, spec.rate_hz, dt_s_);
}

void SensorSuite::reset(std::uint64_t seed) {
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    Runtime& r = runtime_[i];
    const SensorSpec& s = specs_[i];
    r.rng.reseed(sensor_stream_seed(seed, s.name));
    r.next_sample = 0;
    r.next_step = 0;
    r.last_stamp_s = 0.0;
    r.head = r.count = 0;
    r.latest = SensorReading{};
    r.latest.size = r.size;
    r.latest.values.fill(std::numeric_limits<double>::quiet_NaN());
    r.fresh = false;
    if (const auto* imu = std::get_if<ImuParameters>(&s.parameters)) {
      ImuState st;
      reset_imu(*imu, st, r.rng);
      r.state = st;
    } else if (std::holds_alternative<BarometerParameters>(s.parameters)) {
      BarometerState st;
      reset_barometer(st);
      r.state = st;
    } else if (const auto* gps = std::get_if<GpsParameters>(&s.parameters)) {
      GpsState st;
      reset_gps(*gps, st, r.rng);
      r.state = st;
    } else {
      r.state = std::monostate{};
    }
  }
}

void SensorSuite::sample(std::size_t i, const SensorTruth& t) {
  Runtime& r = runtime_[i];
  const SensorSpec& s = specs_[i];
  SensorReading reading;
  reading.stamp_s = t.time_s;
  // The biases' step: the time since the previous sample (the nominal period for the first).
  const double dt = r.next_sample == 0 ? 1.0 / s.rate_hz : t.time_s - r.last_stamp_s;
  double* out = reading.values.data();
  const Mounting& m = s.mounting;
  std::visit(
      [&](const auto& p) {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, ImuParameters>) {
          measure_imu(p, std::get<ImuState>(r.state), m, t, dt, s.rate_hz, r.rng, out);
        } else if constexpr (std::is_same_v<P, MagnetometerParameters>) {
          measure_magnetometer(p, m, t, r.rng, out);
        } else if constexpr (std::is_same_v<P, BarometerParameters>) {
          measure_barometer(p, std::get<BarometerState>(r.state), m, t, dt, r.rng, out);
        } else if constexpr (std::is_same_v<P, GpsParameters>) {
          measure_gps(p, std::get<GpsState>(r.state), m, t, dt, r.rng, out);
        } else if constexpr (std::is_same_v<P, MotionCaptureParameters>) {
          measure_motion_capture(p, m, t, r.rng, out);
        } else if constexpr (std::is_same_v<P, RangeFinderParameters>) {
          measure_range_finder(p, m, t, r.rng, out);
        } else if constexpr (std::is_same_v<P, OpticalFlowParameters>) {
          measure_optical_flow(p, m, t, r.rng, out);
        } else {
          measure_rotor_speeds(p, t, r.rng, out);
        }
      },
      s.parameters);
  reading.size = r.size;
  r.last_stamp_s = t.time_s;
  // Faults act after the noise: the streams and bias processes advance as on a healthy sensor.
  for (std::size_t j = 0; j < s.faults.size(); ++j) {
    const SensorFault& f = s.faults[j];
    if (!f.active_at(t.time_s, dt_s_)) continue;
    if (f.kind == SensorFaultKind::kDropout) return;  // taken, and lost
    reading.values[static_cast<std::size_t>(r.fault_channel[j])] += f.value;
  }
  // The ring cannot overflow: its capacity is the samples one latency holds, plus two.
  r.pending[(r.head + r.count) % r.pending.size()] = reading;
  ++r.count;
}

void SensorSuite::update(std::int64_t step, const SensorTruth& truth) {
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    Runtime& r = runtime_[i];
    r.fresh = false;
    if (step >= r.next_step) {
      sample(i, truth);
      ++r.next_sample;
      r.next_step = std::max(step + 1, step_of_sample(specs_[i], r.next_sample));
    }
    const double latency = specs_[i].latency_s;
    while (r.count > 0) {
      const SensorReading& front = r.pending[r.head];
      if (truth.time_s < front.stamp_s + latency - 1e-9 * dt_s_) break;
      r.latest = front;
      r.fresh = true;
      r.head = (r.head + 1) % r.pending.size();
      --r.count;
    }
  }
}

std::pair<Vec3, Vec3> SensorSuite::imu_bias(int i) const {
  require(i >= 0 && i < size(), "imu_bias: sensor index ", i, " out of range (", size(),
          " sensors)");
  const auto* st = std::get_if<ImuState>(&runtime_[static_cast<std::size_t>(i)].state);
  require(st != nullptr, "imu_bias: sensor ", i, " ('", specs_[static_cast<std::size_t>(i)].name,
          "') is a ", specs_[static_cast<std::size_t>(i)].type_name(), ", not an imu");
  return {st->gyro_bias(), st->accel_bias()};
}

}  // namespace dronetwin
