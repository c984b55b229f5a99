// The batch's OU state noise: each lane follows Eq. 3.5 with the normals of its counter-based
// stream (checked against the dense matrix form of the equation), the noise has the stationary
// covariance the discrete Lyapunov equation gives, and it does not depend on threads, batch size,
// or how steps are grouped; seeds and resets act per lane.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/noise/counter_normal.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using Mat13 = Eigen::Matrix<double, kStateSize, kStateSize>;

SimConfig noisy_config(std::uint64_t seed) {
  SimConfig c;
  c.noise.enabled = true;
  c.seed = seed;
  c.ground.enabled = false;
  return c;
}

template <class T>
void hover_all(BatchSimulator<T>& b) {
  for (int l = 0; l < b.size(); ++l)
    b.reset(l, Simulator::hover_state(Vec3(0.1 * l, 0, 1.0)), b.model().hover_speeds_rad_s());
}

template <class T>
StateVector noise_of(const BatchSimulator<T>& b, int lane) {
  return b.measured_state(lane) - b.state(lane);
}

// Each lane is Eq. 3.5, y_{k+1} = (I - Theta) y_k + sqrt(dt) Sigma xi_k, with xi_k the lane's
// counter draws k * 16 + j: computed here with the dense 13 x 13 matrices.
TEST(BatchNoise, EachLaneFollowsEquation35WithItsCounterStream) {
  const auto model = test::load_model("qdrone2");
  const SimConfig cfg = noisy_config(11);
  constexpr int kLanesUsed = 5, kSteps = 300;
  BatchSimulator<double> b(model, cfg, kLanesUsed);
  hover_all(b);
  b.set_seed(3, 12345);
  b.step(kSteps);
  const Mat13 theta = ou_block_matrix(cfg.noise.parameters.theta);
  const Mat13 sigma = ou_block_matrix(cfg.noise.parameters.sigma);
  for (int l = 0; l < kLanesUsed; ++l) {
    ASSERT_EQ(b.status(l), StepStatus::kOk);
    const std::uint64_t key =
        counter_stream_key(l == 3 ? 12345 : 11, static_cast<std::uint64_t>(l));
    StateVector y = StateVector::Zero();
    for (int k = 0; k < kSteps; ++k) {
      StateVector xi;
      for (int j = 0; j < kStateSize; ++j)
        xi[j] = counter_normal(key, static_cast<std::uint64_t>(k) * kCounterDrawsPerStep +
                                        static_cast<std::uint64_t>(j));
      y = y - theta * y + std::sqrt(cfg.dt_s) * sigma * xi;
    }
    const StateVector got = noise_of(b, l);
    // measured - state recovers the noise to the rounding of the sum (|x| <= 1.4).
    EXPECT_LT((got - y).cwiseAbs().maxCoeff(), 1e-14 * 4) << "lane " << l;
    EXPECT_GT(y.norm(), 1e-4) << "the noise is not trivially zero";
  }
}

// The stationary covariance C of y_{k+1} = A y_k + B xi_k solves C = A C A^T + B B^T; over 4096
// independent lanes (1024 under a sanitizer, with the tolerances widened accordingly) the sample
// covariance matches it.
TEST(BatchNoise, StationaryCovarianceMatchesTheDiscreteLyapunovSolution) {
  const auto model = test::load_model("qdrone2");
  const SimConfig cfg = noisy_config(3);
  const Mat13 A = Mat13::Identity() - ou_block_matrix(cfg.noise.parameters.theta);
  const Mat13 B = std::sqrt(cfg.dt_s) * ou_block_matrix(cfg.noise.parameters.sigma);
  // C = sum_k A^k B B^T A^k^T; the slowest mode decays as 0.99^k.
  Mat13 C = Mat13::Zero(), term = B * B.transpose();
  for (int k = 0; k < 5000; ++k) {
    C += term;
    term = A * term * A.transpose();
  }
  constexpr int kLanesUsed = test::full_or_sanitized(4096, 1024),
                kSteps = 1500;  // 0.99^1500 < 3e-7: stationary
  BatchSimulator<double> b(model, cfg, kLanesUsed, 2);
  hover_all(b);
  b.step(kSteps);
  Mat13 S = Mat13::Zero();
  StateVector mean = StateVector::Zero();
  for (int l = 0; l < kLanesUsed; ++l) {
    ASSERT_EQ(b.status(l), StepStatus::kOk);
    const StateVector y = noise_of(b, l);
    mean += y;
    S += y * y.transpose();
  }
  mean /= kLanesUsed;
  S /= kLanesUsed;
  for (int i = 0; i < kStateSize; ++i) {
    // Sampling error of a variance: sqrt(2/n) relative; of a mean: sqrt(C_ii / n).
    EXPECT_NEAR(S(i, i) / C(i, i), 1.0, 5.0 * std::sqrt(2.0 / kLanesUsed)) << "element " << i;
    EXPECT_NEAR(mean[i], 0.0, 5.0 * std::sqrt(C(i, i) / kLanesUsed)) << "element " << i;
    for (int j = 0; j < i; ++j) {
      // Covariance within a block (correlated by b 1 1^T) and zero across blocks; sampling
      // error of a covariance about sqrt((C_ii C_jj + C_ij^2) / n).
      const double tol = 5.0 * std::sqrt((C(i, i) * C(j, j) + C(i, j) * C(i, j)) / kLanesUsed);
      EXPECT_NEAR(S(i, j), C(i, j), tol) << "elements " << i << ", " << j;
    }
  }
  std::printf("[ noise    ] stationary std of p_x: %.4g (Lyapunov %.4g)\n", std::sqrt(S(0, 0)),
              std::sqrt(C(0, 0)));
}

template <class T>
std::vector<T> noisy_run(int lanes, int threads, bool one_by_one) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<T> b(model, noisy_config(5), lanes, threads);
  hover_all(b);
  for (int l = 0; l < lanes; l += 3) b.set_seed(l, 1000 + static_cast<std::uint64_t>(l));
  if (one_by_one) {
    for (int k = 0; k < 200; ++k) b.step(1);
  } else {
    b.step(120);
    b.step(80);
  }
  std::vector<T> out;
  for (int l = 0; l < lanes; ++l)
    for (int k = 0; k < kStateSize; ++k)
      out.push_back(b.measured_state_data()[static_cast<std::size_t>(k) * b.stride() + l]);
  return out;
}

template <class T>
void expect_same_prefix(const std::vector<T>& a, const std::vector<T>& b, const char* what) {
  const std::size_t n = std::min(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), n * sizeof(T)), 0) << what;
}

TEST(BatchNoise, NoiseIsBitwiseIndependentOfThreadsBatchSizeAndStepGrouping) {
  const std::vector<double> ref = noisy_run<double>(1024, 1, false);
  expect_same_prefix(ref, noisy_run<double>(1024, 2, false), "2 threads");
  expect_same_prefix(ref, noisy_run<double>(7, 1, false), "batch of 7");
  expect_same_prefix(ref, noisy_run<double>(1, 2, false), "batch of 1");
  expect_same_prefix(ref, noisy_run<double>(7, 2, true), "200 x step(1)");
  const std::vector<float> ref32 = noisy_run<float>(1024, 2, false);
  expect_same_prefix(ref32, noisy_run<float>(7, 1, true), "float, batch of 7, step(1)");
}

TEST(BatchNoise, SeedsAndResetsActPerLane) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> b(model, noisy_config(1), 3);
  hover_all(b);
  b.step(50);
  const StateVector lane0 = noise_of(b, 0), lane1 = noise_of(b, 1);
  EXPECT_NE(lane0, lane1) << "lanes of one seed draw different streams";
  // A reset replays the lane's stream (as Simulator::reset does); a new seed draws another.
  b.reset(0, Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
  EXPECT_EQ(noise_of(b, 0), StateVector::Zero());
  b.set_seed(1, 77);
  b.reset(1, Simulator::hover_state(Vec3(0.1, 0, 1.0)), model->hover_speeds_rad_s());
  const StateVector lane2_before = noise_of(b, 2);
  b.step(50);
  EXPECT_LT((noise_of(b, 0) - lane0).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_GT((noise_of(b, 1) - lane1).norm(), 1e-4);
  EXPECT_EQ(b.seed(1), 77u);
  EXPECT_NE(noise_of(b, 2), lane2_before) << "lane 2 went on with its own stream";
  // Noise off: the measured state is the state.
  BatchSimulator<double> quiet(model, SimConfig{}, 2);
  hover_all(quiet);
  quiet.step(10);
  EXPECT_EQ(quiet.measured_state(1), quiet.state(1));
  EXPECT_EQ(quiet.measured_state_data(), quiet.state_data());
}

/// An inner loop that keeps the rotor references and records what it is shown of lane 0.
class Recorder final : public BatchInnerLoop<double> {
 public:
  explicit Recorder(int n) : n_(n) {}
  int size() const override { return n_; }
  int num_rotors() const override { return 4; }
  bool uses_state_derivative() const override { return true; }
  void references(int pack, const Mask&, const StateVectorT<Lanes>& x,
                  const StateVectorT<Lanes>* x_dot, std::array<Lanes, kMaxRotors>&,
                  Mask& failed) override {
    failed = Mask(false);
    if (pack != 0) return;
    StateVector state, derivative;
    for (int k = 0; k < kStateSize; ++k) {
      state[k] = x[k][0];
      derivative[k] = (*x_dot)[k][0];
    }
    measured.push_back(state);
    measured_derivative.push_back(derivative);
  }
  std::vector<StateVector> measured, measured_derivative;

 private:
  int n_;
};

// An inner loop that reads the state derivative sees f(x) at the current rotor speeds (as
// Simulator::state_derivative) plus the derivative's own OU process: Eq. 3.5 with the lane's draws
// 16-28 of each step, checked against the dense matrix form.
TEST(BatchNoise, AnInnerLoopSeesTheDerivativeWithItsOwnOuProcess) {
  const auto model = test::load_model("qdrone2");
  const SimConfig cfg = noisy_config(21);
  BatchSimulator<double> b(model, cfg, 3);
  hover_all(b);
  RotorVector asym = model->hover_speeds_rad_s();
  asym[0] *= 1.01;  // the vehicle accelerates and turns: the derivative is not trivial
  b.set_rotor_speed_reference(0, asym);
  Recorder recorder(3);
  const Mat13 theta = ou_block_matrix(cfg.noise.parameters.theta);
  const Mat13 sigma = ou_block_matrix(cfg.noise.parameters.sigma);
  const std::uint64_t key = counter_stream_key(21, 0);
  StateVector y = StateVector::Zero();
  SimConfig quiet = cfg;
  quiet.noise.enabled = false;
  Simulator sim(model, quiet);
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    sim.reset(b.state(0), b.rotor_speeds(0));
    const StateVector f = sim.state_derivative();
    const StateVector shown = b.measured_state(0);
    ASSERT_EQ(b.step(1, recorder), 0);
    // The controller's measured state is state + state noise, as measured_state_data() holds it.
    ASSERT_EQ(recorder.measured.back(), shown) << "step " << k;
    worst = std::max(worst, (recorder.measured_derivative.back() - (f + y)).cwiseAbs().maxCoeff());
    StateVector xi;
    for (int j = 0; j < kStateSize; ++j)
      xi[j] = counter_normal(key, static_cast<std::uint64_t>(k) * kCounterDrawsPerStep + 16 +
                                      static_cast<std::uint64_t>(j));
    y = y - theta * y + std::sqrt(cfg.dt_s) * sigma * xi;
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_GT(y.norm(), 1e-4) << "the derivative noise is not trivially zero";
}

TEST(BatchNoise, AFailedLaneKeepsItsLastNoise) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> b(model, noisy_config(2), 4);
  hover_all(b);
  b.step(20);
  const StateVector before = noise_of(b, 1);
  b.state_data()[static_cast<std::size_t>(state_index::kVelocity) * b.stride() + 1] =
      std::numeric_limits<double>::quiet_NaN();
  b.step(20);
  EXPECT_EQ(b.status(1), StepStatus::kInvalidState);
  const StateVector m = b.measured_state(1);
  for (int k = 0; k < kStateSize; ++k) {
    if (k == state_index::kVelocity) continue;
    EXPECT_EQ(m[k] - b.state(1)[k], before[k]) << "element " << k;
  }
  EXPECT_EQ(b.status(2), StepStatus::kOk);
  EXPECT_EQ(b.step_count(2), 40);
}

}  // namespace
}  // namespace dronetwin
