#include "dronetwin/control/se3.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

void require_gains(const Vec3& v, const char* field) {
  for (int i = 0; i < 3; ++i)
    require(std::isfinite(v[i]) && v[i] >= 0.0, "se3_geometric: ", field, "[", i,
            "]: expected a finite gain >= 0, got ", v[i]);
}

/// vee of a skew-symmetric matrix: the vector w with hat(w) = S.
Vec3 vee(const Mat3& S) { return Vec3(S(2, 1), S(0, 2), S(1, 0)); }

/// Unit vector along `v`, or nothing usable when |v| is tiny.
bool normalized(const Vec3& v, Vec3& out, double tiny) {
  const double n = v.norm();
  if (!(n > tiny)) return false;
  out = v / n;
  return true;
}

}  // namespace

Vec3 se3_attitude_moment(const Mat3& R, const Vec3& w_B, const Vec3& b3d, double yaw_rad,
                         const Vec3& attitude_p, const Vec3& attitude_d, const Mat3& J) {
  const Vec3 e3 = Vec3::UnitZ();
  // ---- desired attitude R_des = [b2d x b3d, b2d, b3d] (Eq. 3.28) ------------------------------
  const Vec3 b1d(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  Vec3 b2d = Vec3::UnitY();
  // b3d parallel to b1d (a level thrust direction along the heading) leaves b2d undefined; fall
  // back on the current body x axis, then on e3, so R_des stays a rotation.
  if (!normalized(b3d.cross(b1d), b2d, 1e-6) && !normalized(b3d.cross(R.col(0)), b2d, 1e-6))
    normalized(b3d.cross(e3), b2d, 0.0);
  Mat3 R_des;
  R_des.col(0) = b2d.cross(b3d);
  R_des.col(1) = b2d;
  R_des.col(2) = b3d;

  // ---- attitude errors and moment (Eq. 3.27, w_des = 0) ---------------------------------------
  const Vec3 e_R = 0.5 * vee(R_des.transpose() * R - R.transpose() * R_des);
  const Vec3& e_w = w_B;  // w - R^T R_des w_des with w_des = 0 (Eq. 3.28)
  return -attitude_p.cwiseProduct(e_R) - attitude_d.cwiseProduct(e_w) + w_B.cross(J * w_B);
}

Se3Gains Se3Gains::thesis() {
  // Eq. 3.29.
  Se3Gains g;
  g.position_p << 33.5757, 33.5757, 33.0;
  g.position_d << 5.7746, 6.0022, 14.5;
  g.attitude_p << 20.75, 20.75, 1.0;
  g.attitude_d << 4.5, 4.5, 0.05;
  return g;
}

Se3Controller::Se3Controller(std::shared_ptr<const VehicleModel> model, const Se3Gains& gains,
                             const Se3Options& options, AllocationMethod allocation)
    : ControllerBase(std::move(model), allocation), gains_(gains), options_(options) {
  require_gains(gains_.position_p, "position_p");
  require_gains(gains_.position_d, "position_d");
  require_gains(gains_.attitude_p, "attitude_p");
  require_gains(gains_.attitude_d, "attitude_d");
  require(std::isfinite(gains_.mass_kg) && gains_.mass_kg > 0.0,
          "se3_geometric: mass_kg: expected > 0, got ", gains_.mass_kg);
  require(std::isfinite(gains_.gravity_m_s2) && gains_.gravity_m_s2 > 0.0,
          "se3_geometric: gravity_m_s2: expected > 0, got ", gains_.gravity_m_s2);
  require(std::isinf(options_.max_tilt_rad) ||
              (options_.max_tilt_rad > 0.0 && options_.max_tilt_rad < std::numbers::pi / 2),
          "se3_geometric: max_tilt_rad: expected in (0, pi/2) (infinity: no limit), got ",
          options_.max_tilt_rad);
}

std::unique_ptr<ControllerBase> Se3Controller::clone() const {
  return std::make_unique<Se3Controller>(*this);
}

GeneralizedForce Se3Controller::do_calculate_u(const ControlInput& in) {
  using namespace state_index;
  const StateVector& x = in.state;
  const ReferencePoint& ref = in.reference;
  const Vec3 e3 = Vec3::UnitZ();
  const double m = gains_.mass_kg;

  // Measured attitude, normalised (notes #30); a zero quaternion is read as level.
  Vec4 q = x.segment<4>(kQuaternion);
  const double q_norm = q.norm();
  q = q_norm > 1e-12 ? Vec4(q / q_norm) : Vec4(1, 0, 0, 0);
  const Mat3 R = math::rotation_matrix<double>(q);
  const Vec3 w_B = x.segment<3>(kAngularVelocity);

  // ---- desired force, Eq. 3.27-3.28 (+ m g e3, notes #35) -------------------------------------
  const Vec3 e_p = ref.position_m - x.segment<3>(kPosition);
  const Vec3 e_v = ref.velocity_m_s - x.segment<3>(kVelocity);
  Vec3 F = gains_.position_p.cwiseProduct(e_p) + gains_.position_d.cwiseProduct(e_v) +
           m * ref.acceleration_m_s2;
  if (options_.gravity_compensation) F += m * gains_.gravity_m_s2 * e3;

  // ---- desired thrust direction b3d -----------------------------------------------------------
  // |F| below a micro-newton carries no direction: keep b3d = e3 rather than divide by ~0.
  const double tiny_force = 1e-6 * m * gains_.gravity_m_s2;
  Vec3 b3d = e3;
  if (std::isinf(options_.max_tilt_rad)) {
    normalized(F, b3d, tiny_force);
  } else {
    // Cone of half-angle max_tilt around +z. With F inside it nothing changes. Otherwise the
    // horizontal part is shortened so that F lies on the cone (vertical part kept); when F points
    // level or down, b3d is the cone edge on F's horizontal side and F its projection on it.
    const double a = options_.max_tilt_rad, tan_a = std::tan(a);
    const Vec3 F_h(F[0], F[1], 0.0);
    const double h = F_h.norm();
    if (F[2] > 0.0 && h > F[2] * tan_a) {
      F = F_h * (F[2] * tan_a / h) + F[2] * e3;
      normalized(F, b3d, tiny_force);
    } else if (F[2] <= 0.0) {
      Vec3 dir_h = Vec3::Zero();
      if (normalized(F_h, dir_h, tiny_force)) b3d = std::cos(a) * e3 + std::sin(a) * dir_h;
      F = b3d * std::max(F.dot(b3d), 0.0);
    } else {
      normalized(F, b3d, tiny_force);
    }
  }

  // ---- collective thrust f = F . R e3 (Eq. 3.27) ----------------------------------------------
  double f = F.dot(R * e3);
  if (options_.nonnegative_thrust) f = std::max(f, 0.0);

  // ---- attitude law (Eq. 3.27-3.28, w_des = 0) ------------------------------------------------
  const Vec3 M = se3_attitude_moment(R, w_B, b3d, ref.yaw_rad, gains_.attitude_p, gains_.attitude_d,
                                     model().inertia_kgm2());

  GeneralizedForce u;
  u << f, M;
  return u;
}

}  // namespace dronetwin
