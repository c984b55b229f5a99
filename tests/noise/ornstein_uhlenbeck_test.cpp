// Tests for dronetwin::OrnsteinUhlenbeck (noise/ornstein_uhlenbeck.hpp, thesis Sec. 3.4).
//
// The discrete process is linear-Gaussian:
//   Y_{k+1} = A Y_k + B xi_k,   A = I - s Theta,   B = Sigma sqrt(dt),   xi_k ~ N(0, I_13),
// with s = 1 for OuDrift::kPerSample (Eq. 3.5) and s = dt for OuDrift::kContinuous (Eq. 3.4).
// All reference values are computed here from that definition with dense 13x13 matrices:
//   stationary covariance  P = A P A^T + B B^T   (discrete Lyapunov equation, Kronecker solve),
//   lag-m autocovariance   Gamma(m) = Cov(Y_{k+m}, Y_k) = A^m P,
// and every statistical tolerance is 5 standard errors, with the standard error computed from
// the same theory (Bartlett's formula), so it accounts for the time correlation of the samples.
// For a scalar AR(1) with coefficient lambda and correlation time tau = 1 / (1 - lambda), the
// effective sample size is n (1 - lambda^2) / (1 + lambda^2) ~ n / tau for a variance and
// n (1 - lambda) / (1 + lambda) ~ n / (2 tau) for a mean.
//
// Run lengths: with the thesis values Theta = B(0.01, 0.03) the slowest eigenvalue of A is 0.99
// per sample (tau = 100 steps) with kPerSample, which is feasible (4e5 steps ~ 4 000 effective
// samples for the variances, relative SE ~ 2 %). With kContinuous and a realistic dt the thesis
// values give tau = 1 / (0.01 dt), e.g. 1e5 steps at dt = 1 ms, far too long for a unit test, so
// the kContinuous statistics use a larger Theta (tau <= 25 steps); the thesis kContinuous case is
// covered by the exact one-step test.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/ornstein_uhlenbeck.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {
namespace {

using Mat = Eigen::Matrix<double, kStateSize, kStateSize>;

struct DiscreteOu {
  Mat a;  // I - s Theta
  Mat b;  // Sigma sqrt(dt)
};

DiscreteOu discretize(const OuParameters& p, double dt) {
  const double s = p.drift == OuDrift::kPerSample ? 1.0 : dt;
  return {Mat::Identity() - s * ou_block_matrix(p.theta), std::sqrt(dt) * ou_block_matrix(p.sigma)};
}

// Solves P = A P A^T + Q by the Kronecker form (I - A (x) A) vec(P) = vec(Q) (column-major vec:
// vec(A P A^T)[i + n j] = sum_{k,l} A(i,k) A(j,l) P(k,l)).
Mat solve_discrete_lyapunov(const Mat& a, const Mat& q) {
  constexpr int n = kStateSize;
  Eigen::MatrixXd k = Eigen::MatrixXd::Identity(n * n, n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      for (int l = 0; l < n; ++l)
        for (int kk = 0; kk < n; ++kk) k(i + n * j, kk + n * l) -= a(i, kk) * a(j, l);
  const Eigen::VectorXd vq = Eigen::Map<const Eigen::VectorXd>(q.data(), n * n);
  const Eigen::VectorXd vp = k.partialPivLu().solve(vq);
  const Mat p = Eigen::Map<const Mat>(vp.data());
  return 0.5 * (p + p.transpose());
}

// Closed form for the same P, valid because within each block Theta and Sigma are both of the
// form alpha I + beta 1 1^T: they commute, share the eigenvectors 1 (eigenvalues a + N b) and
// 1-perp (eigenvalue a), and the per-eigenvector variance is that of a scalar AR(1):
// v = beta_B^2 / (1 - lambda_A^2).
Mat closed_form_stationary_covariance(const OuParameters& p, double dt) {
  const double s = p.drift == OuDrift::kPerSample ? 1.0 : dt;
  Mat cov = Mat::Zero();
  for (int k = 0; k < 4; ++k) {
    const int n = kOuBlockSize[k], o = kOuBlockOffset[k];
    const double lam_par = 1.0 - s * (p.theta[k].a + n * p.theta[k].b);
    const double lam_perp = 1.0 - s * p.theta[k].a;
    const double b_par = std::sqrt(dt) * (p.sigma[k].a + n * p.sigma[k].b);
    const double b_perp = std::sqrt(dt) * p.sigma[k].a;
    const double v_par = b_par * b_par / (1.0 - lam_par * lam_par);
    const double v_perp = b_perp * b_perp / (1.0 - lam_perp * lam_perp);
    const Eigen::MatrixXd proj = Eigen::MatrixXd::Constant(n, n, 1.0 / n);  // onto span(1)
    cov.block(o, o, n, n) = v_par * proj + v_perp * (Eigen::MatrixXd::Identity(n, n) - proj);
  }
  return cov;
}

// Theoretical second-order structure of the stationary process.
struct Theory {
  Mat stationary;          // P
  std::vector<Mat> gamma;  // gamma[h] = A^h P, h = 0 .. until negligible (+ max lag)
  Mat long_run;            // sum over all h of Gamma(h): n Var(sample mean) -> long_run
};

Theory theory_for(const DiscreteOu& d, int max_lag) {
  Theory t;
  t.stationary = solve_discrete_lyapunov(d.a, d.b * d.b.transpose());
  t.gamma.push_back(t.stationary);
  const double scale = t.stationary.cwiseAbs().maxCoeff();
  // Until |A^h P| < 1e-13 max|P|; then max_lag more for the shifted terms in Bartlett's sum.
  int extra = -1;
  while (extra < max_lag) {
    t.gamma.push_back(d.a * t.gamma.back());
    if (extra >= 0 || t.gamma.back().cwiseAbs().maxCoeff() < 1e-13 * scale) ++extra;
  }
  const Mat inv = (Mat::Identity() - d.a).inverse();
  t.long_run = inv * t.stationary + t.stationary * inv.transpose() - t.stationary;
  return t;
}

// Asymptotic standard errors of c_ij(m) = (1/n) sum_k Y_{k+m,i} Y_{k,j} (known zero mean), from
// Isserlis' theorem for a Gaussian process (Bartlett's formula):
//   n Var c_ij(m) -> sum_h [ G_ii(h) G_jj(h) + G_ij(h + m) G_ji(h - m) ],
// with G(h) = Gamma(h) for h >= 0 and G(-h) = Gamma(h)^T.
Mat lagged_covariance_se(const Theory& t, int m, long n) {
  const int h_max = static_cast<int>(t.gamma.size()) - 1 - m;
  auto g = [&t](int h, int i, int j) {
    return h >= 0 ? t.gamma[static_cast<std::size_t>(h)](i, j)
                  : t.gamma[static_cast<std::size_t>(-h)](j, i);
  };
  Mat se;
  for (int i = 0; i < kStateSize; ++i) {
    for (int j = 0; j < kStateSize; ++j) {
      double sum = 0.0;
      for (int h = -h_max; h <= h_max; ++h) {
        sum += g(h, i, i) * g(h, j, j) + g(h + m, i, j) * g(h - m, j, i);
      }
      se(i, j) = std::sqrt(sum / static_cast<double>(n));
    }
  }
  return se;
}

// One long run: sample mean and lagged second moments c(m) = mean of Y_{k+m} Y_k^T.
struct RunStats {
  StateVector mean = StateVector::Zero();
  std::vector<int> lags;
  std::vector<Mat> lagged;
  long n = 0;
};

RunStats simulate(const OuParameters& p, double dt, std::uint64_t seed, int burn_in, long n,
                  std::vector<int> lags) {
  OrnsteinUhlenbeck ou(p, dt);
  Random rng(seed);
  // Started at Y = 0; the covariance approaches P like lambda^(2k), so burn_in >= 15 tau makes
  // the start-up transient < 1e-13 of P.
  for (int k = 0; k < burn_in; ++k) ou.step(rng);
  const int max_lag = *std::max_element(lags.begin(), lags.end());
  std::vector<StateVector> ring(static_cast<std::size_t>(max_lag + 1));
  RunStats st;
  st.lags = std::move(lags);
  st.lagged.assign(st.lags.size(), Mat::Zero());
  for (long t = 0; t < n + max_lag; ++t) {
    ou.step(rng);
    const StateVector& y = ou.value();
    ring[static_cast<std::size_t>(t % (max_lag + 1))] = y;
    if (t < max_lag) continue;
    st.mean += y;
    for (std::size_t l = 0; l < st.lags.size(); ++l) {
      const StateVector& old = ring[static_cast<std::size_t>((t - st.lags[l]) % (max_lag + 1))];
      st.lagged[l].noalias() += y * old.transpose();
    }
  }
  st.n = n;
  st.mean /= static_cast<double>(n);
  for (Mat& c : st.lagged) c /= static_cast<double>(n);
  return st;
}

// Largest |estimate - expected| / se over all elements must be <= 5.
void expect_within_5_se(const Mat& estimate, const Mat& expected, const Mat& se,
                        const std::string& what) {
  double worst = 0.0;
  int wi = 0, wj = 0;
  for (int i = 0; i < kStateSize; ++i) {
    for (int j = 0; j < kStateSize; ++j) {
      const double z = std::abs(estimate(i, j) - expected(i, j)) / se(i, j);
      if (z > worst) {
        worst = z;
        wi = i;
        wj = j;
      }
    }
  }
  EXPECT_LE(worst, 5.0) << what << ": element (" << wi << ", " << wj << ") estimate "
                        << estimate(wi, wj) << ", theory " << expected(wi, wj) << ", SE "
                        << se(wi, wj);
}

// ---- the three long-run cases ------------------------------------------------------------

struct Case {
  std::string name;
  OuParameters params;
  double dt;
  std::uint64_t seed;
  int burn_in;
  long n;
  std::vector<int> lags;  // lags[0] must be 0
};

// Thesis Eq. 3.8-3.9 with Eq. 3.5 (per-sample drift). A's eigenvalues: 0.99 (multiplicity 9),
// 0.90 (p, v, w along 1), 0.87 (q along 1): tau = 100 steps.
Case thesis_case() {
  return {"thesis, kPerSample", OuParameters::thesis(), 0.002, 101, 3'000, 400'000,
          {0, 1, 10, 50, 100}};
}

// Coupled blocks with different coefficients per block (catches block placement errors) and a
// negative off-diagonal b. A's eigenvalues per block (1 - a, 1 - a - N b):
// p 0.90/0.75, v 0.80/0.50, q 0.95/0.55, w 0.70/0.85: tau = 20 steps.
Case coupled_case() {
  OuParameters p;
  p.theta = {{{0.10, 0.05}, {0.20, 0.10}, {0.05, 0.10}, {0.30, -0.05}}};
  p.sigma = {{{0.5, 0.2}, {1.0, -0.2}, {0.3, 0.3}, {2.0, 0.5}}};
  p.drift = OuDrift::kPerSample;
  return {"coupled, kPerSample", p, 0.01, 202, 1'000, 400'000, {0, 1, 3, 10, 30}};
}

// Scalar-like (b = 0: 13 independent AR(1) components) with Eq. 3.4's dt-scaled drift.
// theta dt = 0.2, 0.1, 0.4, 0.04 per block: A = 0.8, 0.9, 0.6, 0.96, tau <= 25 steps.
Case continuous_scalar_case() {
  OuParameters p;
  p.theta = {{{50.0, 0.0}, {25.0, 0.0}, {100.0, 0.0}, {10.0, 0.0}}};
  p.sigma = {{{0.5, 0.0}, {1.0, 0.0}, {0.2, 0.0}, {2.0, 0.0}}};
  p.drift = OuDrift::kContinuous;
  return {"scalar-like, kContinuous", p, 0.004, 303, 1'000, 400'000, {0, 1, 5, 25}};
}

struct CaseResult {
  Case c;
  DiscreteOu d;
  Theory theory;
  RunStats stats;
};

CaseResult run_case(Case c) {
  const DiscreteOu d = discretize(c.params, c.dt);
  Theory theory = theory_for(d, *std::max_element(c.lags.begin(), c.lags.end()));
  RunStats stats = simulate(c.params, c.dt, c.seed, c.burn_in, c.n, c.lags);
  return {std::move(c), d, std::move(theory), std::move(stats)};
}

// Each long run is simulated once and shared by the statistics tests below.
const std::vector<CaseResult>& long_runs() {
  static const std::vector<CaseResult> runs = [] {
    std::vector<CaseResult> r;
    r.push_back(run_case(thesis_case()));
    r.push_back(run_case(coupled_case()));
    r.push_back(run_case(continuous_scalar_case()));
    return r;
  }();
  return runs;
}

// ---- parameters and block matrices -------------------------------------------------------

TEST(OuParametersTest, ThesisValuesMatchEq38And39) {
  const OuParameters p = OuParameters::thesis();
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(p.theta[k].a, 0.01);
    EXPECT_EQ(p.theta[k].b, 0.03);
    EXPECT_EQ(p.sigma[k].a, 0.005);
    EXPECT_EQ(p.sigma[k].b, 0.003);
  }
  EXPECT_EQ(p.drift, OuDrift::kPerSample);  // Eq. 3.5 as printed is the default
}

TEST(OuBlockMatrixTest, MatchesBlockDefinition) {
  // B_N(a, b) = a I + b 1 1^T per block, blocks p(0-2), v(3-5), q(6-9), w(10-12).
  const std::array<BlockCoefficients, 4> blocks{
      {{1.0, 10.0}, {2.0, 20.0}, {3.0, 30.0}, {4.0, 40.0}}};
  const Mat m = ou_block_matrix(blocks);
  auto block_of = [](int i) { return i < 3 ? 0 : i < 6 ? 1 : i < 10 ? 2 : 3; };
  for (int i = 0; i < kStateSize; ++i) {
    for (int j = 0; j < kStateSize; ++j) {
      const int bi = block_of(i);
      double expected = 0.0;
      if (bi == block_of(j)) expected = (i == j ? 1.0 + bi : 0.0) + 10.0 * (bi + 1);
      EXPECT_EQ(m(i, j), expected) << "(" << i << ", " << j << ")";
    }
  }
}

// ---- one exact step ----------------------------------------------------------------------

// From a known Y (reached by stepping) and a known generator state, one step must equal
// A Y + B xi with xi the next 13 normals of a copy of the generator, and must consume exactly
// those 13 normals. Tolerance, componentwise: 1e-15 (about 9 ulp) of the scale
// (|A| |Y| + |B| |xi|)_i; both evaluations are sums of at most ~8 rounded terms, whose forward
// error is bounded by a few ulp of that scale.
TEST(OrnsteinUhlenbeckTest, OneStepMatchesDenseFormula) {
  OuParameters thesis_continuous = OuParameters::thesis();
  thesis_continuous.drift = OuDrift::kContinuous;
  const std::vector<std::pair<OuParameters, double>> cases{
      {OuParameters::thesis(), 0.002},
      {thesis_continuous, 0.01},
      {coupled_case().params, 0.01},
      {continuous_scalar_case().params, 0.004}};
  int index = 0;
  for (const auto& [params, dt] : cases) {
    SCOPED_TRACE("case " + std::to_string(index++));
    const DiscreteOu d = discretize(params, dt);
    OrnsteinUhlenbeck ou(params, dt);
    Random rng(77);
    for (int k = 0; k < 25; ++k) ou.step(rng);
    for (int k = 0; k < 5; ++k) {  // several consecutive steps, each from a known Y
      const StateVector y = ou.value();
      Random copy = rng;
      StateVector xi;
      for (int i = 0; i < kStateSize; ++i) xi[i] = copy.normal();
      const StateVector expected = d.a * y + d.b * xi;
      const StateVector scale = d.a.cwiseAbs() * y.cwiseAbs() + d.b.cwiseAbs() * xi.cwiseAbs();
      ou.step(rng);
      for (int i = 0; i < kStateSize; ++i) {
        EXPECT_NEAR(ou.value()[i], expected[i], 1e-15 * scale[i]) << "step " << k << ", i " << i;
      }
      EXPECT_EQ(rng.next_u64(), copy.next_u64()) << "step must draw exactly 13 normals";
    }
  }
}

// ---- stationary statistics ---------------------------------------------------------------

// Checks the test's own reference: the Kronecker Lyapunov solution equals the closed form and
// satisfies the equation.
TEST(OrnsteinUhlenbeckTest, LyapunovReferenceMatchesClosedForm) {
  for (const Case& c : {thesis_case(), coupled_case(), continuous_scalar_case()}) {
    SCOPED_TRACE(c.name);
    const DiscreteOu d = discretize(c.params, c.dt);
    const Mat p = solve_discrete_lyapunov(d.a, d.b * d.b.transpose());
    const Mat closed = closed_form_stationary_covariance(c.params, c.dt);
    const double scale = closed.cwiseAbs().maxCoeff();
    EXPECT_LT((p - closed).cwiseAbs().maxCoeff(), 1e-11 * scale);
    const Mat residual = p - d.a * p * d.a.transpose() - d.b * d.b.transpose();
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-13 * scale);
  }
}

TEST(OrnsteinUhlenbeckTest, SampleMeanIsZero) {
  for (const CaseResult& r : long_runs()) {
    SCOPED_TRACE(r.c.name);
    // SE of the mean of a correlated series: sqrt(S_ii / n), S = sum_h Gamma(h).
    for (int i = 0; i < kStateSize; ++i) {
      const double se = std::sqrt(r.theory.long_run(i, i) / static_cast<double>(r.stats.n));
      EXPECT_NEAR(r.stats.mean[i], 0.0, 5.0 * se) << "component " << i;
    }
  }
}

TEST(OrnsteinUhlenbeckTest, StationaryCovarianceMatchesLyapunovSolution) {
  for (const CaseResult& r : long_runs()) {
    SCOPED_TRACE(r.c.name);
    ASSERT_EQ(r.stats.lags[0], 0);
    // The sample covariance (about the known mean 0) against P, including the zero blocks
    // between physical quantities (the thesis' "spatially uncorrelated" property).
    expect_within_5_se(r.stats.lagged[0], r.theory.stationary,
                       lagged_covariance_se(r.theory, 0, r.stats.n), "lag 0");
  }
}

TEST(OrnsteinUhlenbeckTest, LaggedAutocovarianceMatchesPowersOfA) {
  for (const CaseResult& r : long_runs()) {
    SCOPED_TRACE(r.c.name);
    for (std::size_t l = 1; l < r.stats.lags.size(); ++l) {
      const int m = r.stats.lags[l];
      // Cov(Y_{k+m}, Y_k) = A^m P = gamma[m], computed independently of gamma as a matrix power.
      Mat a_m = Mat::Identity();
      for (int k = 0; k < m; ++k) a_m = r.d.a * a_m;
      expect_within_5_se(r.stats.lagged[l], a_m * r.theory.stationary,
                         lagged_covariance_se(r.theory, m, r.stats.n), "lag " + std::to_string(m));
    }
  }
}

// Eq. 3.4 discretised with a dt-scaled drift: each component of the scalar-like case is an
// AR(1) with lambda = 1 - theta dt and noise sigma sqrt(dt), so its stationary variance is
// sigma^2 dt / (1 - (1 - theta dt)^2). The SE of a sample variance of an AR(1) is
// v sqrt(2 (1 + lambda^2) / ((1 - lambda^2) n)) (Bartlett), computed here without the matrix
// machinery above.
TEST(OrnsteinUhlenbeckTest, ContinuousDriftScalarVarianceMatchesClosedForm) {
  const CaseResult& r = long_runs()[2];
  ASSERT_EQ(r.c.params.drift, OuDrift::kContinuous);
  const double dt = r.c.dt;
  for (int k = 0; k < 4; ++k) {
    const double theta = r.c.params.theta[k].a, sigma = r.c.params.sigma[k].a;
    ASSERT_EQ(r.c.params.theta[k].b, 0.0);
    ASSERT_EQ(r.c.params.sigma[k].b, 0.0);
    const double lambda = 1.0 - theta * dt;
    const double v = sigma * sigma * dt / (1.0 - lambda * lambda);
    const double se = v * std::sqrt(2.0 * (1.0 + lambda * lambda) /
                                    ((1.0 - lambda * lambda) * static_cast<double>(r.stats.n)));
    for (int j = 0; j < kOuBlockSize[k]; ++j) {
      const int i = kOuBlockOffset[k] + j;
      EXPECT_NEAR(r.stats.lagged[0](i, i), v, 5.0 * se) << "component " << i;
    }
  }
}

// ---- state handling and determinism ------------------------------------------------------

TEST(OrnsteinUhlenbeckTest, ResetZeroesTheState) {
  const OuParameters params = coupled_case().params;
  OrnsteinUhlenbeck ou(params, 0.01);
  EXPECT_TRUE(ou.value().isZero(0.0));  // starts at zero
  Random rng(8);
  for (int k = 0; k < 10; ++k) ou.step(rng);
  ASSERT_FALSE(ou.value().isZero(0.0));
  ou.reset();
  EXPECT_TRUE(ou.value().isZero(0.0));
  // After a reset the process continues exactly like a fresh one.
  OrnsteinUhlenbeck fresh(params, 0.01);
  Random rng_fresh = rng;
  for (int k = 0; k < 20; ++k) {
    ou.step(rng);
    fresh.step(rng_fresh);
    ASSERT_EQ(std::memcmp(ou.value().data(), fresh.value().data(), sizeof(double) * kStateSize), 0)
        << "step " << k;
  }
  EXPECT_EQ(ou.parameters().theta[0].a, params.theta[0].a);  // reset keeps the parameters
}

TEST(OrnsteinUhlenbeckTest, EqualSeedsGiveBitwiseEqualPaths) {
  OuParameters params = OuParameters::thesis();
  for (OuDrift drift : {OuDrift::kPerSample, OuDrift::kContinuous}) {
    params.drift = drift;
    OrnsteinUhlenbeck a(params, 0.001), b(params, 0.001), c(params, 0.001);
    Random ra(2718), rb(2718), rc(2719);
    int differs_from_other_seed = 0;
    for (int k = 0; k < 2'000; ++k) {
      a.step(ra);
      b.step(rb);
      c.step(rc);
      ASSERT_EQ(std::memcmp(a.value().data(), b.value().data(), sizeof(double) * kStateSize), 0)
          << "step " << k;
      differs_from_other_seed += a.value() != c.value() ? 1 : 0;
    }
    EXPECT_EQ(differs_from_other_seed, 2'000);
  }
}

}  // namespace
}  // namespace dronetwin
