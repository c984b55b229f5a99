#include "dronetwin/estimation/sensor_fusion.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/math/rotation_vector.hpp"

namespace dronetwin {

namespace {

int find_sensor(const std::vector<SensorSpec>& specs, const std::string& name, const char* field) {
  for (std::size_t i = 0; i < specs.size(); ++i)
    if (specs[i].name == name) return static_cast<int>(i);
  std::string names;
  for (const SensorSpec& s : specs) names += (names.empty() ? "" : ", ") + s.name;
  throw InvalidArgument(detail::concat(field, ": no sensor named '", name,
                                       "' (sensors: ", names.empty() ? "none" : names, ")"));
}

constexpr std::size_t kImu = 0, kMag = 1, kBaro = 2, kGps = 3, kMocap = 4, kRange = 5, kFlow = 6;

Vec3 values3(const SensorReading& r, int first) {
  return Vec3(r.values[static_cast<std::size_t>(first)],
              r.values[static_cast<std::size_t>(first + 1)],
              r.values[static_cast<std::size_t>(first + 2)]);
}

}  // namespace

SensorFusion::SensorFusion(const std::vector<SensorSpec>& specs, const FusionSettings& settings,
                           const StateVector& initial_state)
    : specs_(specs),
      imu_(find_sensor(specs, settings.imu, "imu")),
      ekf_([&] {
        const SensorSpec& imu = specs[static_cast<std::size_t>(imu_)];
        const auto* p = std::get_if<ImuParameters>(&imu.parameters);
        require(p != nullptr, "imu: sensor '", settings.imu, "' is a ", imu.type_name(),
                ", not an imu");
        return EkfParameters::from_imu(*p, imu.mounting);
      }()),
      estimate_(initial_state) {
  for (std::size_t k = 0; k < settings.updates.size(); ++k) {
    const std::string field = detail::concat("updates[", k, "]");
    const int i = find_sensor(specs, settings.updates[k], field.c_str());
    const std::size_t type = specs[static_cast<std::size_t>(i)].parameters.index();
    require(type != kImu && type < 7, field, ": the filter cannot use a ",
            specs[static_cast<std::size_t>(i)].type_name(),
            " (it fuses motion_capture, gps, barometer, magnetometer, range_finder, optical_flow)");
    for (const Update& u : update_)
      require(u.sensor != i, field, ": '", settings.updates[k], "' is listed twice");
    update_.push_back({i, type});
  }
  ekf_.reset(initial_state, 0.0);
}

void SensorFusion::process(const SensorSuite& suite) {
  if (suite.fresh(imu_)) {
    const SensorReading& r = suite.latest(imu_);
    if (imu_started_) {
      ekf_.propagate(values3(r, 0), values3(r, 3), r.stamp_s - last_imu_stamp_s_);
    }
    imu_started_ = true;
    last_imu_stamp_s_ = r.stamp_s;
  }
  for (const Update& u : update_) {
    if (!suite.fresh(u.sensor)) continue;
    const SensorReading& r = suite.latest(u.sensor);
    const SensorSpec& s = specs_[static_cast<std::size_t>(u.sensor)];
    const Vec3& lever = s.mounting.position_B_m;
    // A late reading describes the vehicle `age` ago: carried forward to now with the estimated
    // velocity and body rates (first order), so a 5 ms motion-capture delay at 2 m/s does not
    // read as a 1 cm position error.
    const double age = std::max(0.0, ekf_.time_s() - r.stamp_s);
    const Vec3 moved = ekf_.velocity() * age;
    switch (u.type) {
      case kMocap: {
        const auto& p = std::get<MotionCaptureParameters>(s.parameters);
        ekf_.update_position(values3(r, 0) + moved, std::max(p.position_noise_m, 1e-6), lever);
        const Vec4 q_WS(r.values[3], r.values[4], r.values[5], r.values[6]);
        const Vec4& q_BS = s.mounting.rotation_BS_wxyz;
        const Vec4 q_SB = math::conjugate(q_BS);
        const Vec3 turn = ekf_.state().segment<3>(state_index::kAngularVelocity) * age;
        ekf_.update_attitude(
            math::multiply<double>(math::multiply<double>(q_WS, q_SB), math::rotation_exp(turn)),
            std::max(p.attitude_noise_rad, 1e-6));
        break;
      }
      case kGps: {
        const auto& p = std::get<GpsParameters>(s.parameters);
        const double sp = std::sqrt(
            (p.position_noise_m.array().square() + p.position_error_m.array().square()).maxCoeff());
        ekf_.update_position(values3(r, 0) + moved, std::max(sp, 1e-6), lever);
        ekf_.update_velocity(values3(r, 3), std::max(p.velocity_noise_m_s.maxCoeff(), 1e-6));
        break;
      }
      case kBaro: {
        const auto& p = std::get<BarometerParameters>(s.parameters);
        const double h = isa_altitude_m(r.values[0]) - p.origin_altitude_m;
        // rho g at this altitude: the pressure drop over one metre.
        const double rho_g = isa_pressure_Pa(p.origin_altitude_m + h) -
                             isa_pressure_Pa(p.origin_altitude_m + h + 1.0);
        const double lever_z = (math::rotation_matrix<double>(ekf_.attitude()) * lever)[2];
        ekf_.update_height(h - lever_z, std::max(p.noise_Pa / rho_g, 1e-4));
        break;
      }
      case kMag: {
        const auto& p = std::get<MagnetometerParameters>(s.parameters);
        ekf_.update_magnetometer(values3(r, 0) - p.hard_iron_uT, p.field_W_uT,
                                 std::max(p.noise_uT, 1e-3), s.mounting);
        break;
      }
      case kFlow: {
        const auto& p = std::get<OpticalFlowParameters>(s.parameters);
        const Eigen::Vector2d flow(r.values[0], r.values[1]);
        if (!flow.allFinite()) continue;
        ekf_.update_optical_flow(flow, std::max(p.noise_rad_s, 1e-4), s.mounting);
        break;
      }
      case kRange: {
        const auto& p = std::get<RangeFinderParameters>(s.parameters);
        const double d = r.values[0];
        if (!std::isfinite(d)) continue;
        ekf_.update_range(d, std::max(p.noise_m + p.noise_fraction * d, 1e-4), s.mounting);
        break;
      }
    }
    ++updates_;
  }
  estimate_ = ekf_.state();
}

}  // namespace dronetwin
