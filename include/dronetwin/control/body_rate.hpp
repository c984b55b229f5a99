#pragma once
// BodyRateController: collective thrust + body rates (CTBR), the command of state-of-the-art
// racing policies (thesis Sec. 2.3 lists CTBR among the virtual inputs; Sec. 4.3 flies policies).
// A command [T, w_cmd] becomes generalized forces by a proportional rate loop with the gyroscopic
// term cancelled:
//   tau = J (K_w (w_cmd - w_B)) + w_B x J w_B,    u = [T, tau]
// so that, with ideal actuators, J w_dot = tau - w x J w gives w_dot = K_w (w_cmd - w): each body
// rate follows its command as a first-order lag of time constant 1 / K_w. The allocation
// (thrust first) then makes rotor speeds.
//
//   BodyRateController rates(model, BodyRateGains{});
//   rates.set_command(model->mass_kg() * 9.81, Vec3(0, 0, 1.0));   // hover thrust, yaw at 1 rad/s
//   const SetpointReference unused(Vec3::Zero());                    // the loop needs one
//   ClosedLoop loop(sim, rates, unused, 1000.0);
//
// The law is written once for any lane scalar (body_rate_law), the batched controller
// (batch/batch_body_rate.hpp) instantiates it on a pack.
//
// Trap: the reference of ClosedLoop is ignored; the command is what set_command() last gave.

#include <memory>
#include <string_view>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/core/scalar.hpp"
#include "dronetwin/math/ordered_product.hpp"

namespace dronetwin {

struct BodyRateGains {
  /// K_w per body axis, 1/s: the inverse time constant of each rate's response. Not from the
  /// thesis (it has no rate controller): about 20 rad/s in roll and pitch, half in yaw, well
  /// below the QDrone2's motor bandwidth (1 / 0.5 ms) and the 100 Hz of a policy.
  Vec3 rate_p = Vec3(20.0, 20.0, 10.0);
};

/// tau = J (K_w (w_cmd - w_B)) + w_B x J w_B, sums in a fixed order (equal for every scalar).
template <class S>
Vector3<S> body_rate_law(const Vec3& rate_p, const Mat3& J, const Vector3<S>& w_B,
                         const Vector3<S>& rate_cmd) {
  using V = scalar::value_type_t<S>;
  Vector3<S> a;
  for (int i = 0; i < 3; ++i) a[i] = scalar::from_value<S>(rate_p[i]) * (rate_cmd[i] - w_B[i]);
  const Vector3<S> Ja = math::ordered_product(J.cast<V>(), a);
  const Vector3<S> gyro = w_B.cross(math::ordered_product(J.cast<V>(), w_B));
  return Ja + gyro;
}

class BodyRateController final : public ControllerBase {
 public:
  /// Throws InvalidArgument for negative or non-finite gains.
  BodyRateController(std::shared_ptr<const VehicleModel> model, const BodyRateGains& gains,
                     AllocationMethod allocation = AllocationMethod::kExact);

  std::string_view name() const override { return "body_rate"; }
  std::unique_ptr<ControllerBase> clone() const override;
  bool uses_state_derivative() const override { return false; }
  /// Back to zero thrust and zero rates.
  void reset() override;

  /// The CTBR command: collective thrust (N, >= 0) and body rates (rad/s). InvalidArgument for
  /// non-finite values or a negative thrust.
  void set_command(double thrust_N, const Vec3& rates_rad_s);
  double thrust_command_N() const { return thrust_N_; }
  const Vec3& rate_command_rad_s() const { return rates_rad_s_; }
  const BodyRateGains& gains() const { return gains_; }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;

 private:
  BodyRateGains gains_;
  double thrust_N_ = 0.0;
  Vec3 rates_rad_s_ = Vec3::Zero();
};

}  // namespace dronetwin
