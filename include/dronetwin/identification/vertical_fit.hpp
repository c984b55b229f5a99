#pragma once
// Equation-error fit of the vertical force balance on a real flight log (a dronetwin log with
// rotor speeds, attitude and world-frame specific force acc_z = dvz/dt + g, e.g. from
// io/crazypad_import.hpp):
//
//   acc_z = dvz/dt + g = c F_z - d vz,   F_z = [R(q) sum_i T_i(omega_i) a_i]_z
//
// with T_i the model's thrust polynomial (Eq. 2.22) along rotor axis a_i, evaluated by the force
// kernel with the thrust term alone (for coplanar rotors F_z = R_33 sum_i T_i, R_33 =
// cos(roll) cos(pitch) the z component of the body z axis), c = s / m the thrust scale per unit
// mass (1/kg) and d = k_z / m a linear vertical drag per unit mass (1/s). If the stand thrust is
// taken as true (s = 1), m = 1 / c.
//
//   VerticalFitResult r = fit_vertical(read_csv_log("E8.csv"), model);
//   r.fit.coefficients  -> c, d;  r.mass_kg = 1 / c;  r.rms_test_m_s2 vs r.rms_test_prior_m_s2
//
// Samples: airborne only (z > min_height_m and every omega_i > 0, so no ground reaction); the
// first train_fraction of them (in time) are fitted, the rest are held out. The "prior"
// prediction uses c = 1 / prior_mass_kg and d = 0 (no fit).
// Trap: this is an equation-error fit on estimated accelerations; the residual includes the
// estimator's lag and noise, and the standard errors assume independent samples (they are not:
// 101 Hz samples of a smooth flight), so they are optimistic.

#include <string>

#include "dronetwin/identification/linear_fit.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

struct VerticalFitOptions {
  double train_fraction = 0.7;
  bool fit_drag = true;
  /// Airborne threshold on z. The CrazyPAD E8 flight lands between its two hops where the
  /// estimator reads z = 0.10 m, so the threshold must be above that.
  double min_height_m = 0.15;
  /// Mass for the no-fit prediction; 0 means the model's mass (negative or NaN is an error).
  double prior_mass_kg = 0.0;
};

struct VerticalFitResult {
  LinearFit fit;                   ///< "c" (1/kg) and, with fit_drag, "d" (1/s)
  double mass_kg = 0.0;            ///< 1 / c
  double mass_std_error_kg = 0.0;  ///< se(c) / c^2
  double prior_mass_kg = 0.0;
  std::size_t num_train = 0, num_test = 0;
  double t_split_s = 0.0;  ///< first held-out sample time
  double rms_train_m_s2 = 0.0;
  double rms_test_m_s2 = 0.0;        ///< held-out residual with the fitted c, d
  double rms_test_prior_m_s2 = 0.0;  ///< held-out residual with c = 1 / prior mass, d = 0
  /// Per selected sample (train then test, in time order): t, measured acc_z, F_z, vz.
  std::vector<double> t_s, lhs_m_s2, thrust_z_N, vz_m_s;
};

VerticalFitResult fit_vertical(const LogTable& log, const VehicleModel& model,
                               const VerticalFitOptions& options = {});

}  // namespace dronetwin
