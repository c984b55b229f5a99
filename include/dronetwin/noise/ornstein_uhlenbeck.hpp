#pragma once
// Ornstein-Uhlenbeck measurement noise on the 13-element state (thesis Sec. 3.4, Eq. 3.3-3.10).
//
// Discrete process, one sample per physics step of length dt:
//   Y_{k+1} = Y_k - Theta Y_k + Sigma sqrt(dt) xi_k,   xi_k ~ N(0, I_13)      (Eq. 3.5, default)
//   Y_{k+1} = Y_k - Theta Y_k dt + Sigma sqrt(dt) xi_k                          (Eq. 3.4,
//   `continuous`)
// Theta and Sigma are block diagonal with one block per physical quantity in state order
// (p 3, v 3, q 4, w 3; notes #28), each block B_N(a, b) = a I + b 1 1^T (Eq. 3.8-3.9). Because a
// block is "a I + b 1 1^T", applying it costs O(N): a y + b sum(y).
//
//   OrnsteinUhlenbeck ou(OuParameters::thesis(), dt);
//   ou.step(rng);                         // advance one physics step
//   StateVector measured = x + ou.value();
//
// Trap: with Eq. 3.5 the decay per *sample* is Theta, so the correlation time is measured in
// steps, not seconds; changing dt changes the noise's time scale (thesis as printed).

#include <array>
#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {

/// Block matrix B_N(a, b) = a I + b 1 1^T.
struct BlockCoefficients {
  double a = 0.0;
  double b = 0.0;
};

enum class OuDrift {
  kPerSample,   ///< -Theta Y (thesis Eq. 3.5 literally)
  kContinuous,  ///< -Theta Y dt (thesis Eq. 3.4, Euler-Maruyama)
};

struct OuParameters {
  /// Theta and Sigma per state block: position, velocity, quaternion, angular velocity.
  std::array<BlockCoefficients, 4> theta{};
  std::array<BlockCoefficients, 4> sigma{};
  OuDrift drift = OuDrift::kPerSample;

  /// Thesis Eq. 3.8-3.9: Theta blocks B(0.01, 0.03), Sigma blocks B(0.005, 0.003).
  static OuParameters thesis() {
    OuParameters p;
    p.theta.fill({0.01, 0.03});
    p.sigma.fill({0.005, 0.003});
    return p;
  }
};

/// Sizes and offsets of the four blocks inside the state vector.
inline constexpr std::array<int, 4> kOuBlockSize{3, 3, 4, 3};
inline constexpr std::array<int, 4> kOuBlockOffset{0, 3, 6, 10};

/// Dense 13x13 form of a block-diagonal B_N(a, b) matrix (for tests and analysis).
inline Eigen::Matrix<double, kStateSize, kStateSize> ou_block_matrix(
    const std::array<BlockCoefficients, 4>& blocks) {
  Eigen::Matrix<double, kStateSize, kStateSize> m =
      Eigen::Matrix<double, kStateSize, kStateSize>::Zero();
  for (int k = 0; k < 4; ++k) {
    const int n = kOuBlockSize[k], o = kOuBlockOffset[k];
    m.block(o, o, n, n).setConstant(blocks[k].b);
    m.block(o, o, n, n).diagonal().array() += blocks[k].a;
  }
  return m;
}

/// One block of Eq. 3.4/3.5 for any scalar (double, float, a pack of lanes): advances the N values
/// y[0..N) with the standard normals xi[0..N) by
///   y_j += -drift_scale (theta_a y_j + theta_b sum(y)) + sqrt_dt (sigma_a xi_j + sigma_b sum(xi)),
/// B_N(a, b) y = a y + b sum(y) (Eq. 3.8-3.9). The scalar process and the batch share it.
template <int N, class S>
inline void ou_update_block(S* y, const S* xi, const S& theta_a, const S& theta_b, const S& sigma_a,
                            const S& sigma_b, const S& drift_scale, const S& sqrt_dt) {
  S sum_y(0), sum_xi(0);
  for (int j = 0; j < N; ++j) {
    sum_y += y[j];
    sum_xi += xi[j];
  }
  for (int j = 0; j < N; ++j) {
    const S theta_y = theta_a * y[j] + theta_b * sum_y;
    const S sigma_xi = sigma_a * xi[j] + sigma_b * sum_xi;
    y[j] += -drift_scale * theta_y + sqrt_dt * sigma_xi;
  }
}

class OrnsteinUhlenbeck {
 public:
  OrnsteinUhlenbeck() = default;
  OrnsteinUhlenbeck(const OuParameters& p, double dt_s) : params_(p) {
    sqrt_dt_ = std::sqrt(dt_s);
    drift_scale_ = p.drift == OuDrift::kPerSample ? 1.0 : dt_s;
  }

  const StateVector& value() const { return y_; }
  void reset() { y_.setZero(); }
  const OuParameters& parameters() const { return params_; }

  /// Advances one step: draws 13 standard normals from `rng`.
  void step(Random& rng) {
    std::array<double, kStateSize> xi;
    // Draw from a local copy so the generator state can live in registers for the 13 draws.
    Random local = rng;
    for (double& v : xi) v = local.normal();
    rng = local;
    // Block sizes are compile-time constants so each block's loops unroll.
    update_block<3>(0, xi);
    update_block<3>(1, xi);
    update_block<4>(2, xi);
    update_block<3>(3, xi);
  }

 private:
  template <int N>
  void update_block(int k, const std::array<double, kStateSize>& xi) {
    const auto b = static_cast<std::size_t>(k);
    const int o = kOuBlockOffset[b];
    ou_update_block<N>(y_.data() + o, xi.data() + o, params_.theta[b].a, params_.theta[b].b,
                       params_.sigma[b].a, params_.sigma[b].b, drift_scale_, sqrt_dt_);
  }

  OuParameters params_{};
  double sqrt_dt_ = 0.0;
  double drift_scale_ = 1.0;
  StateVector y_ = StateVector::Zero();
};

}  // namespace dronetwin
