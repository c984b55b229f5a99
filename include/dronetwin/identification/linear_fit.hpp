#pragma once
// Least squares for models that are linear in their parameters, y ~ A p, solved with Ceres and
// reported with standard errors from Ceres' covariance estimate:
//
//   se_j = sqrt( sigma^2 [(A^T A)^-1]_jj ),   sigma^2 = sum r_i^2 / (n - p)
//
// (the usual unweighted-regression estimate; it assumes independent residuals of equal variance,
// which real time series only approximate — treat the errors as optimistic there).
//
//   Eigen::MatrixXd A(n, 3);  A.col(0) = w.square(); A.col(1) = w; A.col(2).setOnes();
//   LinearFit f = fit_linear(A, T, {"K1", "K2", "K3"}, "thrust stand");
//   double k1 = f.coefficients[0], se = f.std_errors[0], rms = f.residual_rms;
//
// Columns are scaled to unit max-abs internally (thrust curves mix w^2 ~ 1e7 with 1), so the
// solver and the covariance see a well-conditioned problem; results are unscaled back.
// Trap: a rank-deficient A (a constant column twice, too few distinct rows) is an error naming the
// fit, not a silent minimum-norm answer.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace dronetwin {

struct LinearFit {
  std::vector<std::string> names;
  std::vector<double> coefficients;
  std::vector<double> std_errors;
  double residual_rms = 0.0;  ///< sqrt(mean r^2) over the rows used
  std::size_t num_points = 0;
  int solver_iterations = 0;
  /// A p for new rows (A with the same columns).
  Eigen::VectorXd predict(const Eigen::MatrixXd& a) const;
};

/// Fits y ~ A p (A: n x p, n > p). `what` names the fit in errors.
LinearFit fit_linear(const Eigen::MatrixXd& a, const Eigen::VectorXd& y,
                     std::vector<std::string> names, const std::string& what);

}  // namespace dronetwin
