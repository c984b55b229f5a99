#pragma once
// The vehicle-model parameters that `dronetwin fit` can identify, by name, and how a fit reads
// them from and writes them into a VehicleSpec (or the parameters of a built model: a batch
// varies them per lane, batch/batch_simulator.hpp).
//
//   std::vector<ModelParameter> p = parse_parameter_list("thrust,body_drag,mass");
//   double k1 = parameter_value(spec, ModelParameter::kThrustK1);       // mean over rotors
//   set_parameter_value(spec, ModelParameter::kThrustK1, 1.05 * k1);     // every rotor x 1.05
//
// Per-rotor coefficients are fitted as ONE multiplier shared by all rotors, so a model whose
// rotors differ keeps their ratios. Names and groups (model-format.md spells the fields):
//   mass                         mass_kg
//   inertia_xx, _yy, _zz         diagonal of inertia_kgm2 (off-diagonal terms are kept)
//   thrust_k1, _k2, _k3          thrust_coefficients 'K1, 'K2, 'K3 (Eq. 2.22)
//   yaw_moment_per_thrust        1/K_tau (Eq. 2.23)
//   drag_moment                  C_MD (Eq. 2.32)
//   rotor_drag                   C_D (Eq. 2.32)
//   rolling_moment               C_R (Eq. 2.32)
//   body_drag_x, _y, _z          diagonal of body_drag_Ns_per_m (Eq. 2.32)
//   ground_effect                C_G (appendix C.2)
//   tau_rise, tau_fall           motor time constants (Eq. 2.43-2.45)
//   groups: thrust, inertia, body_drag, motor
//
// Trap: yaw_moment_per_thrust and drag_moment enter the yaw moment only as eps (1/K_tau - C_MD) T
// (Eq. 2.24 + 2.32): together they are not identifiable, and the fit says so (correlation -1).

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

enum class ModelParameter : int {
  kMass = 0,
  kInertiaXX,
  kInertiaYY,
  kInertiaZZ,
  kThrustK1,
  kThrustK2,
  kThrustK3,
  kYawMomentPerThrust,
  kDragMoment,
  kRotorDrag,
  kRollingMoment,
  kBodyDragX,
  kBodyDragY,
  kBodyDragZ,
  kGroundEffect,
  kTauRise,
  kTauFall,
};
inline constexpr int kNumModelParameters = 17;

/// The name used on the command line and in reports ("thrust_k1", ...).
std::string_view parameter_name(ModelParameter p);
/// Unit of the parameter's value (SI).
std::string_view parameter_unit(ModelParameter p);
/// True for tau_rise / tau_fall: identified from rotor speeds, not from accelerations.
inline bool is_motor_parameter(ModelParameter p) {
  return p == ModelParameter::kTauRise || p == ModelParameter::kTauFall;
}

/// Parses a comma-separated list of names and groups (duplicates removed, canonical order).
/// InvalidArgument naming the unknown entry and listing the valid names.
std::vector<ModelParameter> parse_parameter_list(std::string_view list);

/// The parameter's value in `spec`: the number itself, or the mean over the rotors.
double parameter_value(const VehicleSpec& spec, ModelParameter p);

/// Writes `value` into `spec`: per-rotor coefficients are scaled so that their mean becomes
/// `value` (all set to it when the mean is 0).
void set_parameter_value(VehicleSpec& spec, ModelParameter p, double value);

/// The same two on the parameters of a built model (what a batch lane varies).
double parameter_value(const VehicleParametersTpl<double>& parameters, ModelParameter p);
void set_parameter_value(VehicleParametersTpl<double>& parameters, ModelParameter p, double value);

}  // namespace dronetwin
