// Vertical force-balance fit (include/dronetwin/identification/vertical_fit.hpp).
#include "dronetwin/identification/vertical_fit.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

VerticalFitResult fit_vertical(const LogTable& log, const VehicleModel& model,
                               const VerticalFitOptions& options) {
  require(options.train_fraction > 0.0 && options.train_fraction < 1.0,
          "fit_vertical: train_fraction must be in (0, 1), got ", options.train_fraction);
  require(std::isfinite(options.prior_mass_kg) && options.prior_mass_kg >= 0.0,
          "fit_vertical: prior_mass_kg must be a mass in kg > 0 (or 0 for the model's), got ",
          options.prior_mass_kg);
  require(std::isfinite(options.min_height_m),
          "fit_vertical: min_height_m must be a finite height in m, got ", options.min_height_m);
  const int nr = model.num_rotors();
  const std::size_t ct = log.column("t"), cz = log.column("z"), cvz = log.column("vz"),
                    cqw = log.column("qw"), cqx = log.column("qx"), cqy = log.column("qy"),
                    cqz = log.column("qz"), ca = log.column("acc_z");
  std::vector<std::size_t> comega;
  for (int i = 0; i < nr; ++i) comega.push_back(log.column("omega_" + std::to_string(i)));

  VerticalFitResult r;
  r.prior_mass_kg = options.prior_mass_kg > 0.0 ? options.prior_mass_kg : model.mass_kg();
  // The thrust term of the force kernel alone (Eq. 2.22 along each rotor axis).
  const ForceKernel<double> thrust_only(model, ForceTerms::only(Term::kThrust));
  HeldRotorTerms<double> held;
  RotorVector speeds(nr);
  for (std::size_t row = 0; row < log.rows(); ++row) {
    if (!(log.at(row, cz) > options.min_height_m)) continue;
    bool spinning = true;
    for (int i = 0; i < nr; ++i) {
      speeds[i] = log.at(row, comega[static_cast<std::size_t>(i)]);
      spinning = spinning && speeds[i] > 0.0;
    }
    if (!spinning) continue;
    thrust_only.prepare(speeds, held);  // thrust is state independent: the constant part
    Vec4 q(log.at(row, cqw), log.at(row, cqx), log.at(row, cqy), log.at(row, cqz));
    q.normalize();
    const Mat3 R = math::rotation_matrix<double>(q);
    r.t_s.push_back(log.at(row, ct));
    r.lhs_m_s2.push_back(log.at(row, ca));  // specific force, already includes g
    r.thrust_z_N.push_back(R.row(2).dot(held.constant.head<3>()));  // world z of the thrust
    r.vz_m_s.push_back(log.at(row, cvz));
  }
  const std::size_t n = r.t_s.size();
  require(n >= 20, log.source, ": only ", n, " airborne samples (z > ", options.min_height_m,
          " m, all rotors spinning); need at least 20");
  r.num_train =
      static_cast<std::size_t>(std::floor(options.train_fraction * static_cast<double>(n)));
  r.num_test = n - r.num_train;
  require(r.num_train >= 10 && r.num_test >= 10, log.source, ": train/test split ", r.num_train,
          "/", r.num_test, " leaves fewer than 10 samples on a side");
  r.t_split_s = r.t_s[r.num_train];

  const int p = options.fit_drag ? 2 : 1;
  const auto design = [&](std::size_t from, std::size_t count) {
    Eigen::MatrixXd a(static_cast<Eigen::Index>(count), p);
    for (std::size_t k = 0; k < count; ++k) {
      a(static_cast<Eigen::Index>(k), 0) = r.thrust_z_N[from + k];
      if (p == 2) a(static_cast<Eigen::Index>(k), 1) = -r.vz_m_s[from + k];
    }
    return a;
  };
  const auto target = [&](std::size_t from, std::size_t count) {
    return Eigen::Map<const Eigen::VectorXd>(r.lhs_m_s2.data() + from,
                                             static_cast<Eigen::Index>(count));
  };
  std::vector<std::string> names = {"c"};
  if (p == 2) names.push_back("d");
  r.fit = fit_linear(design(0, r.num_train), target(0, r.num_train), names,
                     log.source + ": vertical fit");
  r.rms_train_m_s2 = r.fit.residual_rms;
  const Eigen::MatrixXd a_test = design(r.num_train, r.num_test);
  const Eigen::VectorXd y_test = target(r.num_train, r.num_test);
  const auto rms = [](const Eigen::VectorXd& e) {
    return std::sqrt(e.squaredNorm() / static_cast<double>(e.size()));
  };
  r.rms_test_m_s2 = rms(r.fit.predict(a_test) - y_test);
  r.rms_test_prior_m_s2 = rms(a_test.col(0) / r.prior_mass_kg - y_test);
  const double c = r.fit.coefficients[0];
  require(c > 0.0, log.source, ": fitted thrust per mass c = ", c, " is not positive");
  r.mass_kg = 1.0 / c;
  r.mass_std_error_kg = r.fit.std_errors[0] / (c * c);
  return r;
}

}  // namespace dronetwin
