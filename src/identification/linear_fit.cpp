// Linear-in-parameters least squares with Ceres (include/dronetwin/identification/linear_fit.hpp).
#include "dronetwin/identification/linear_fit.hpp"

#include <ceres/ceres.h>
#include <ceres/covariance.h>

#include <cmath>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

/// r = a . p - y for one row; the Jacobian is the row itself.
class RowResidual final : public ceres::CostFunction {
 public:
  RowResidual(const double* row, int p, double y) : row_(row), p_(p), y_(y) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(p);
  }
  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    double r = -y_;
    for (int j = 0; j < p_; ++j) r += row_[j] * params[0][j];
    residuals[0] = r;
    if (jacobians && jacobians[0]) {
      for (int j = 0; j < p_; ++j) jacobians[0][j] = row_[j];
    }
    return true;
  }

 private:
  const double* row_;
  int p_;
  double y_;
};

}  // namespace

Eigen::VectorXd LinearFit::predict(const Eigen::MatrixXd& a) const {
  require(a.cols() == static_cast<Eigen::Index>(coefficients.size()), "LinearFit::predict: A has ",
          a.cols(), " columns, expected ", coefficients.size());
  return a * Eigen::Map<const Eigen::VectorXd>(coefficients.data(), a.cols());
}

LinearFit fit_linear(const Eigen::MatrixXd& a, const Eigen::VectorXd& y,
                     std::vector<std::string> names, const std::string& what) {
  const Eigen::Index n = a.rows(), p = a.cols();
  require(p >= 1 && static_cast<Eigen::Index>(names.size()) == p, what, ": ", p, " columns but ",
          names.size(), " parameter names");
  require(y.size() == n, what, ": ", n, " rows in A but ", y.size(), " values");
  require(n > p, what, ": need more rows than parameters, got ", n, " rows for ", p);
  require(a.allFinite() && y.allFinite(), what, ": non-finite value in the data");

  // Scale each column to max-abs 1; row-major copy so a residual can point at its row.
  Eigen::VectorXd scale(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double m = a.col(j).cwiseAbs().maxCoeff();
    require(m > 0.0, what, ": column ", j, " (", names[static_cast<std::size_t>(j)],
            ") is all zero");
    scale[j] = m;
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> as =
      a * scale.cwiseInverse().asDiagonal();
  const double y_scale = std::max(y.cwiseAbs().maxCoeff(), 1e-300);
  const Eigen::VectorXd ys = y / y_scale;

  std::vector<double> x(static_cast<std::size_t>(p), 0.0);
  ceres::Problem::Options popts;
  popts.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(popts);
  for (Eigen::Index i = 0; i < n; ++i) {
    problem.AddResidualBlock(new RowResidual(as.data() + i * p, static_cast<int>(p), ys[i]),
                             nullptr, x.data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 20;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-16;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  require(summary.IsSolutionUsable(), what, ": Ceres failed: ", summary.message);

  ceres::Covariance::Options copts;
  copts.algorithm_type = ceres::DENSE_SVD;
  copts.num_threads = 1;
  ceres::Covariance covariance(copts);
  std::vector<std::pair<const double*, const double*>> blocks = {{x.data(), x.data()}};
  require(covariance.Compute(blocks, &problem), what,
          ": the parameters are not identifiable from these data (rank-deficient Jacobian)");
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cov(p, p);
  covariance.GetCovarianceBlock(x.data(), x.data(), cov.data());

  LinearFit fit;
  fit.names = std::move(names);
  fit.num_points = static_cast<std::size_t>(n);
  fit.solver_iterations = static_cast<int>(summary.iterations.size());
  const Eigen::Map<const Eigen::VectorXd> xs(x.data(), p);
  const Eigen::VectorXd coef = y_scale * xs.cwiseQuotient(scale);
  const Eigen::VectorXd r = a * coef - y;
  const double ssr = r.squaredNorm();
  fit.residual_rms = std::sqrt(ssr / static_cast<double>(n));
  const double sigma2 = ssr / static_cast<double>(n - p);
  for (Eigen::Index j = 0; j < p; ++j) {
    fit.coefficients.push_back(coef[j]);
    // cov is (As^T As)^-1 in scaled units; unscale to the original parameter.
    fit.std_errors.push_back(std::sqrt(sigma2 * cov(j, j)) / scale[j]);
  }
  return fit;
}

}  // namespace dronetwin
