// The policy network (mlp.hpp): validation and the allocation-free evaluator.
#include "dronetwin/policy/mlp.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

int Mlp::input_size() const { return weights.empty() ? 0 : static_cast<int>(weights[0].cols()); }

int Mlp::output_size() const {
  return weights.empty() ? 0 : static_cast<int>(weights.back().rows());
}

std::vector<int> Mlp::layer_widths() const {
  std::vector<int> widths;
  if (weights.empty()) return widths;
  widths.push_back(input_size());
  for (const Eigen::MatrixXd& w : weights) widths.push_back(static_cast<int>(w.rows()));
  return widths;
}

namespace {

/// The first non-finite entry of `m` as "[i, j]" (or "[i]" for a vector), "" when all are finite.
template <class Derived>
std::string first_non_finite(const Eigen::MatrixBase<Derived>& m) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (std::isfinite(m(i, j))) continue;
      return m.cols() == 1 ? detail::concat("[", i, "] is ", m(i, j))
                           : detail::concat("[", i, ", ", j, "] is ", m(i, j));
    }
  }
  return {};
}

}  // namespace

void validate(const Mlp& mlp) {
  require(!mlp.weights.empty(), "mlp: weights: expected at least one layer, got none");
  require(mlp.biases.size() == mlp.weights.size(), "mlp: biases: expected ", mlp.weights.size(),
          " (one per layer), got ", mlp.biases.size());
  const int in = mlp.input_size();
  for (std::size_t k = 0; k < mlp.weights.size(); ++k) {
    const Eigen::MatrixXd& w = mlp.weights[k];
    const Eigen::Index expected_cols = k == 0 ? w.cols() : mlp.weights[k - 1].rows();
    require(w.rows() >= 1 && w.rows() <= Mlp::kMaxWidth, "mlp: weights[", k, "]: expected 1 to ",
            Mlp::kMaxWidth, " rows (outputs), got ", w.rows());
    require(w.cols() >= 1 && w.cols() <= Mlp::kMaxWidth, "mlp: weights[", k, "]: expected 1 to ",
            Mlp::kMaxWidth, " columns (inputs), got ", w.cols());
    require(w.cols() == expected_cols, "mlp: weights[", k, "]: expected ", expected_cols,
            " columns (the rows of weights[", k - 1, "]), got ", w.cols());
    require(mlp.biases[k].size() == w.rows(), "mlp: biases[", k, "]: expected ", w.rows(),
            " entries (the rows of weights[", k, "]), got ", mlp.biases[k].size());
    const std::string bad_w = first_non_finite(w);
    require(bad_w.empty(), "mlp: weights[", k, "]: expected finite numbers, entry ", bad_w);
    const std::string bad_b = first_non_finite(mlp.biases[k]);
    require(bad_b.empty(), "mlp: biases[", k, "]: expected finite numbers, entry ", bad_b);
  }
  require(mlp.observation_mean.size() == in, "mlp: observation_mean: expected ", in,
          " entries (the input size), got ", mlp.observation_mean.size());
  require(mlp.observation_std.size() == in, "mlp: observation_std: expected ", in,
          " entries (the input size), got ", mlp.observation_std.size());
  const std::string bad_mean = first_non_finite(mlp.observation_mean);
  require(bad_mean.empty(), "mlp: observation_mean: expected finite numbers, entry ", bad_mean);
  for (Eigen::Index i = 0; i < in; ++i) {
    const double s = mlp.observation_std[i];
    require(std::isfinite(s) && s > 0, "mlp: observation_std: expected finite numbers > 0, entry [",
            i, "] is ", s);
  }
  require(std::isfinite(mlp.observation_clip) && mlp.observation_clip > 0,
          "mlp: observation_clip: expected a finite number > 0, got ", mlp.observation_clip);
  const int out = mlp.output_size();
  require(mlp.action_scale.size() == out, "mlp: action_scale: expected ", out,
          " entries (the output size), got ", mlp.action_scale.size());
  const std::string bad_scale = first_non_finite(mlp.action_scale);
  require(bad_scale.empty(), "mlp: action_scale: expected finite numbers, entry ", bad_scale);
  const int activation = static_cast<int>(mlp.activation);
  require(activation >= 0 && activation < 3,
          "mlp: activation: expected leaky_relu, relu or tanh, "
          "got the value ",
          activation);
  require(std::isfinite(mlp.negative_slope), "mlp: negative_slope: expected a finite number, got ",
          mlp.negative_slope);
  const int output = static_cast<int>(mlp.output);
  require(output >= 0 && output < 2, "mlp: output: expected tanh or identity, got the value ",
          output);
}

MlpEvaluator::MlpEvaluator(std::shared_ptr<const Mlp> mlp) : mlp_(std::move(mlp)) {
  require(mlp_ != nullptr, "MlpEvaluator: expected a network, got a null pointer");
  validate(*mlp_);
  input_size_ = mlp_->input_size();
  output_size_ = mlp_->output_size();
  Eigen::Index widest = input_size_;
  for (const Eigen::MatrixXd& w : mlp_->weights) widest = std::max(widest, w.rows());
  a_.setZero(widest);
  b_.setZero(widest);
}

template <class In, class Out>
void MlpEvaluator::evaluate_row(const In* observation, Out* action, std::ptrdiff_t row) {
  const Mlp& m = *mlp_;
  for (int i = 0; i < input_size_; ++i) {
    const auto o = static_cast<double>(observation[i]);
    if (!std::isfinite(o)) {
      throw InvalidArgument(row < 0 ? detail::concat("MlpEvaluator: observation[", i,
                                                     "]: expected a finite number, got ", o)
                                    : detail::concat("MlpEvaluator: observations[", row, ", ", i,
                                                     "]: expected a finite number, got ", o));
    }
    a_[i] = std::clamp((o - m.observation_mean[i]) / m.observation_std[i], -m.observation_clip,
                       m.observation_clip);
  }
  // Ping-pong between a_ and b_: layer k reads `x` (its input) and writes `y`. Plain loops, not
  // Eigen expressions: nothing can allocate, and each output sums b_i + W_i0 x_0 + W_i1 x_1 + ...
  // in that order whatever the SIMD width. Column by column (W is column-major), so the inner
  // loop is an axpy over contiguous memory, which vectorises without reordering any sum.
  double* x = a_.data();
  double* y = b_.data();
  const std::size_t last = m.weights.size() - 1;
  for (std::size_t k = 0; k <= last; ++k) {
    const Eigen::MatrixXd& w = m.weights[k];
    const Eigen::Index out = w.rows(), in = w.cols();
    const double* bias = m.biases[k].data();
    for (Eigen::Index i = 0; i < out; ++i) y[i] = bias[i];
    for (Eigen::Index j = 0; j < in; ++j) {
      const double xj = x[j];
      const double* column = w.data() + j * out;
      for (Eigen::Index i = 0; i < out; ++i) y[i] += column[i] * xj;
    }
    if (k < last) {
      switch (m.activation) {
        case Mlp::Activation::kLeakyRelu:
          for (Eigen::Index i = 0; i < out; ++i) y[i] = y[i] > 0 ? y[i] : m.negative_slope * y[i];
          break;
        case Mlp::Activation::kRelu:
          for (Eigen::Index i = 0; i < out; ++i) y[i] = y[i] > 0 ? y[i] : 0.0;
          break;
        case Mlp::Activation::kTanh:
          for (Eigen::Index i = 0; i < out; ++i) y[i] = std::tanh(y[i]);
          break;
      }
    }
    std::swap(x, y);
  }
  // The last layer's output is in x now.
  const bool squash = m.output == Mlp::OutputSquash::kTanh;
  for (int i = 0; i < output_size_; ++i) {
    const double z = x[i];
    const auto a = static_cast<Out>(m.action_scale[i] * (squash ? std::tanh(z) : z));
    if (!std::isfinite(a)) {  // in Out: a float action may overflow where the double did not
      throw InvalidArgument(detail::concat("MlpEvaluator: action[", i, "] is ", a,
                                           ": the network overflows for this observation"));
    }
    action[i] = a;
  }
}

template <class In, class Out>
void MlpEvaluator::evaluate(const In* observation, Out* action) {
  evaluate_row(observation, action, -1);
}

template <class In, class Out>
void MlpEvaluator::evaluate_rows(const In* observations, std::ptrdiff_t rows, Out* actions) {
  require(rows >= 0, "MlpEvaluator: rows: expected a count >= 0, got ", rows);
  for (std::ptrdiff_t r = 0; r < rows; ++r)
    evaluate_row(observations + r * input_size_, actions + r * output_size_, r);
}

template void MlpEvaluator::evaluate(const double*, double*);
template void MlpEvaluator::evaluate(const float*, double*);
template void MlpEvaluator::evaluate(const double*, float*);
template void MlpEvaluator::evaluate(const float*, float*);
template void MlpEvaluator::evaluate_rows(const double*, std::ptrdiff_t, double*);
template void MlpEvaluator::evaluate_rows(const float*, std::ptrdiff_t, double*);
template void MlpEvaluator::evaluate_rows(const double*, std::ptrdiff_t, float*);
template void MlpEvaluator::evaluate_rows(const float*, std::ptrdiff_t, float*);

}  // namespace dronetwin
