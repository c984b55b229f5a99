#include "dronetwin/model/vehicle_model.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

double rotor_speed_for_thrust(const std::array<double, 3>& coefficients, double min_speed_rad_s,
                              double max_speed_rad_s, double thrust_N) {
  return inverse_thrust_polynomial<double>(coefficients, min_speed_rad_s, max_speed_rad_s,
                                           thrust_N);
}

namespace {

std::string where(const VehicleSpec& s) { return s.source.empty() ? s.name : s.source; }

template <class Derived>
void require_finite(const VehicleSpec& s, const std::string& field, const Derived& m) {
  if (m.allFinite()) return;
  std::ostringstream values;
  values.precision(17);
  const auto e = m.derived().eval();
  for (Eigen::Index k = 0; k < e.size(); ++k) values << (k ? ", " : "") << e.data()[k];
  require(false, where(s), ": ", field, ": expected finite numbers, got [", values.str(), "]");
}

void require_finite(const VehicleSpec& s, const std::string& field, double v) {
  require(std::isfinite(v), where(s), ": ", field, ": expected a finite number, got ", v);
}

void validate_collision(const VehicleSpec& s, const CollisionShape& c) {
  require_finite(s, "collision.center_m", c.center_B_m);
  if (c.kind == CollisionShape::Kind::kSphere) {
    require_finite(s, "collision.radius_m", c.radius_m);
    require(c.radius_m > 0.0, where(s), ": collision.radius_m: expected > 0, got ", c.radius_m);
  } else {
    require_finite(s, "collision.half_size_m", c.half_size_m);
    require(c.half_size_m.minCoeff() > 0.0, where(s),
            ": collision.half_size_m: expected three numbers > 0, got [", c.half_size_m.transpose(),
            "]");
  }
}

void validate_rotor(const VehicleSpec& s, std::size_t i) {
  const RotorParams& r = s.rotors[i];
  const std::string f = "rotors[" + std::to_string(i) + "].";
  require_finite(s, f + "position_m", r.position_m);
  require_finite(s, f + "axis", r.axis);
  require(r.axis.norm() > 1e-9, where(s), ": ", f, "axis: expected a non-zero direction, got [",
          r.axis.transpose(), "]");
  require(r.spin == 1 || r.spin == -1, where(s), ": ", f, "spin: expected +1 or -1, got ", r.spin);
  for (int k = 0; k < 3; ++k)
    require_finite(s, f + "thrust_coefficients[" + std::to_string(k) + "]",
                   r.thrust_coefficients[static_cast<std::size_t>(k)]);
  const struct {
    const char* name;
    double value;
  } non_negative[] = {
      {"yaw_moment_per_thrust_m", r.yaw_moment_per_thrust_m},
      {"rotor_drag_coefficient", r.rotor_drag_coefficient},
      {"rolling_moment_coefficient", r.rolling_moment_coefficient},
      {"drag_moment_coefficient", r.drag_moment_coefficient},
      {"ground_effect_coefficient", r.ground_effect_coefficient},
      {"inertia_kgm2", r.inertia_kgm2},
      {"time_constant_rise_s", r.time_constant_rise_s},
      {"time_constant_fall_s", r.time_constant_fall_s},
      {"min_speed_rad_s", r.min_speed_rad_s},
  };
  for (const auto& p : non_negative) {
    require_finite(s, f + p.name, p.value);
    require(p.value >= 0.0, where(s), ": ", f, p.name, ": expected >= 0, got ", p.value);
  }
  require_finite(s, f + "max_speed_rad_s", r.max_speed_rad_s);
  require(r.max_speed_rad_s > r.min_speed_rad_s, where(s), ": ", f,
          "max_speed_rad_s: expected > min_speed_rad_s (", r.min_speed_rad_s, "), got ",
          r.max_speed_rad_s);
  // The thrust curve must rise over the whole speed range, otherwise its inverse (used by the
  // allocation and the hover trim) is not unique. dT/dw = 2 a w + b is linear in w, so checking
  // both ends of the range suffices.
  const double a = r.thrust_coefficients[0], b = r.thrust_coefficients[1];
  require(a >= 0.0, where(s), ": ", f, "thrust_coefficients[0]: expected >= 0, got ", a);
  const double slope_min = 2 * a * r.min_speed_rad_s + b;
  const double slope_max = 2 * a * r.max_speed_rad_s + b;
  require(slope_max > 0.0 && slope_min >= 0.0, where(s), ": ", f,
          "thrust_coefficients: thrust must increase with speed on [min_speed_rad_s, "
          "max_speed_rad_s]; got dT/dw = ",
          slope_min, " at min and ", slope_max, " at max");
}

}  // namespace

VehicleModel::Validated VehicleModel::validate(VehicleSpec spec) {
  const VehicleSpec& s = spec;
  require_finite(s, "mass_kg", s.mass_kg);
  require(s.mass_kg > 0.0, where(s), ": mass_kg: expected > 0, got ", s.mass_kg);
  require_finite(s, "inertia_kgm2", s.inertia_kgm2);
  require((s.inertia_kgm2 - s.inertia_kgm2.transpose()).cwiseAbs().maxCoeff() <=
              1e-12 * s.inertia_kgm2.cwiseAbs().maxCoeff(),
          where(s), ": inertia_kgm2: expected a symmetric matrix, got\n", s.inertia_kgm2);
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(s.inertia_kgm2);
  const Vec3 principal = eig.eigenvalues();
  require(principal.minCoeff() > 0.0, where(s),
          ": inertia_kgm2: expected a positive-definite matrix, got eigenvalues [",
          principal.transpose(), "]");
  // Physical inertia tensors satisfy the triangle inequality on the principal moments.
  require(principal[0] + principal[1] >= principal[2] * (1 - 1e-9), where(s),
          ": inertia_kgm2: principal moments [", principal.transpose(),
          "] violate the triangle inequality (J1 + J2 >= J3), no rigid body has them");
  require_finite(s, "body_drag_Ns_per_m", s.body_drag_Ns_per_m);
  // Drag may only dissipate energy: v^T A v >= 0 for all v, i.e. the symmetric part of A is
  // positive semi-definite.
  const Vec3 drag_eig = Eigen::SelfAdjointEigenSolver<Mat3>(
                            0.5 * (s.body_drag_Ns_per_m + s.body_drag_Ns_per_m.transpose()))
                            .eigenvalues();
  require(drag_eig.minCoeff() >= 0.0, where(s),
          ": body_drag_Ns_per_m: expected a dissipative (positive semi-definite) matrix, got "
          "eigenvalues [",
          drag_eig.transpose(), "] of its symmetric part");
  require_finite(s, "ground_effect_min_height_m", s.ground_effect_min_height_m);
  require(s.ground_effect_min_height_m > 0.0, where(s),
          ": ground_effect_min_height_m: expected > 0, got ", s.ground_effect_min_height_m);
  if (s.collision) validate_collision(s, *s.collision);
  const auto n = s.rotors.size();
  require(n >= 1 && n <= static_cast<std::size_t>(kMaxRotors), where(s),
          ": rotors: expected between 1 and ", kMaxRotors, " rotors, got ", n);
  for (std::size_t i = 0; i < n; ++i) validate_rotor(s, i);
  for (auto& r : spec.rotors) r.axis.normalize();

  VehicleParametersTpl<double> p;
  p.num_rotors = static_cast<int>(n);
  for (std::size_t i = 0; i < n; ++i) p.rotors[i] = spec.rotors[i];
  p.mass_kg = spec.mass_kg;
  p.inertia_kgm2 = spec.inertia_kgm2;
  p.body_drag_Ns_per_m = spec.body_drag_Ns_per_m;
  p.ground_effect_min_height_m = spec.ground_effect_min_height_m;
  return {std::move(spec), std::move(p)};
}

VehicleModel::VehicleModel(VehicleSpec spec) : VehicleModel(validate(std::move(spec))) {}

VehicleModel::VehicleModel(Validated validated)
    : VehicleModelTpl<double>(std::move(validated.second)), spec_(std::move(validated.first)) {
  const VehicleSpec& s = spec_;
  const int nr = num_rotors();
  wrench_.resize(6, nr);
  allocation_.resize(4, nr);
  for (int i = 0; i < nr; ++i) {
    const RotorParams& r = rotor(i);
    const Vec3 moment = r.position_m.cross(r.axis) + r.spin * r.yaw_moment_per_thrust_m * r.axis;
    wrench_.col(i) << r.axis, moment;
    allocation_.col(i) << r.axis.z(), moment;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd_a(Eigen::MatrixXd(allocation_),
                                                Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd sv = svd_a.singularValues();
  const double tol = 1e-9 * sv.maxCoeff();
  int rank = 0;
  for (Eigen::Index k = 0; k < sv.size(); ++k) rank += sv[k] > tol ? 1 : 0;
  require(rank == 4, where(s),
          ": rotors: the allocation matrix (thrust and three moments per unit rotor thrust) has "
          "rank ",
          rank,
          ", expected 4; these rotors cannot produce independent thrust, roll, pitch and yaw");
  allocation_pinv_ =
      Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(Eigen::MatrixXd(allocation_))
          .pseudoInverse();
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod_w{Eigen::MatrixXd(wrench_)};
  wrench_pinv_ = cod_w.pseudoInverse();
  wrench_rank_ = static_cast<int>(cod_w.rank());
  if (s.collision) {
    collision_ = *s.collision;
  } else {
    double hub_m = 0.0;
    for (int i = 0; i < nr; ++i) hub_m = std::max(hub_m, rotor(i).position_m.norm());
    collision_ = CollisionShape::sphere(hub_m + 0.1);
  }
}

RotorVector VehicleModel::hover_thrusts_N(double gravity_m_s2) const {
  Eigen::Matrix<double, 6, 1> w;
  w << 0, 0, mass_kg() * gravity_m_s2, 0, 0, 0;
  return wrench_pinv_ * w;
}

RotorVector VehicleModel::hover_speeds_rad_s(double gravity_m_s2) const {
  const RotorVector thrusts = hover_thrusts_N(gravity_m_s2);
  RotorVector w(num_rotors());
  for (int i = 0; i < num_rotors(); ++i) w[i] = rotor(i).speed_for_thrust(thrusts[i]);
  return w;
}

bool VehicleModel::can_hover(double gravity_m_s2) const {
  const RotorVector thrusts = hover_thrusts_N(gravity_m_s2);
  for (int i = 0; i < num_rotors(); ++i) {
    const RotorParams& r = rotor(i);
    if (!(thrusts[i] >= r.thrust(r.min_speed_rad_s) && thrusts[i] <= r.thrust(r.max_speed_rad_s)))
      return false;
  }
  return true;
}

RotorVector VehicleModel::thrusts_for(const GeneralizedForce& u) const {
  return allocation_pinv_ * u;
}

}  // namespace dronetwin
