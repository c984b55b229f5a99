#pragma once
// The network of a trained policy (docs/policy-format.md, "The function"): a multilayer
// perceptron with frozen observation normalisation and a squashed, scaled output,
//
//   h_0 = clip((o - observation_mean) / observation_std, -observation_clip, +observation_clip)
//   h_k = act(W_k h_{k-1} + b_k)                  k = 1 .. L-1  (leaky_relu / relu / tanh)
//   a   = action_scale ⊙ out(W_L h_{L-1} + b_L)                 (out: tanh or identity)
//
// `Mlp` is plain data (read from a .dtpolicy file by config/policy_io.hpp, or filled in by
// hand); `MlpEvaluator` computes the function in double with a workspace allocated once, so that
// evaluating an observation allocates nothing.
//
//   auto mlp = std::make_shared<const Mlp>(read_policy("hover.dtpolicy").mlp);
//   MlpEvaluator policy(mlp);                      // validates the network
//   std::vector<double> obs(mlp->input_size()), action(mlp->output_size());
//   policy.evaluate(obs.data(), action.data());
//   policy.evaluate_rows(observations, n, actions);  // n row-major rows in, n rows out
//
// Trap: an evaluator owns its workspace, so one evaluator is used by one thread at a time; give
// each thread its own (they share the Mlp).

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string_view>
#include <vector>

namespace dronetwin {

struct Mlp {
  /// The non-linearity after every layer but the last.
  enum class Activation { kLeakyRelu, kRelu, kTanh };
  /// What the last layer's output goes through before action_scale.
  enum class OutputSquash { kTanh, kIdentity };

  /// Widest layer an Mlp may have (also the reader's bound on a file's widths).
  static constexpr int kMaxWidth = 65536;

  Eigen::VectorXd observation_mean;      ///< [input_size]
  Eigen::VectorXd observation_std;       ///< [input_size], every entry > 0
  double observation_clip = 10.0;        ///< > 0: the normalised observation is clipped to ±this
  std::vector<Eigen::MatrixXd> weights;  ///< W_k, [out, in]; weights[0] takes the observation
  std::vector<Eigen::VectorXd> biases;   ///< b_k, [out]
  Activation activation = Activation::kLeakyRelu;
  double negative_slope = 0.2;  ///< leaky_relu's slope for negative inputs
  OutputSquash output = OutputSquash::kTanh;
  Eigen::VectorXd action_scale;  ///< [output_size]

  /// The observation size: weights[0].cols() (0 without layers).
  int input_size() const;
  /// The action size: weights.back().rows() (0 without layers).
  int output_size() const;
  /// The widths, input first and output last ([input_size, hidden..., output_size]; empty
  /// without layers).
  std::vector<int> layer_widths() const;
};

/// The names of the enums as the file writes them: "leaky_relu", "relu", "tanh" and "tanh",
/// "identity" (indexed by the enum's value).
inline constexpr std::string_view kActivationNames[] = {"leaky_relu", "relu", "tanh"};
inline constexpr std::string_view kOutputSquashNames[] = {"tanh", "identity"};

/// Throws InvalidArgument "mlp: <field>: expected <...>, got <...>" unless `mlp` describes a
/// network MlpEvaluator can evaluate: at least one layer; weights[k] of shape [out, in] with in
/// the previous layer's out, widths in [1, kMaxWidth]; biases[k] of size out; observation_mean,
/// observation_std of input_size() and action_scale of output_size() entries; every number
/// finite; observation_std > 0; observation_clip > 0; a known activation and output.
void validate(const Mlp& mlp);

/// Evaluates an Mlp (the function above) in double, allocating nothing after construction.
class MlpEvaluator {
 public:
  /// Validates the network (validate()) and allocates the workspace. InvalidArgument for a null
  /// pointer or an invalid network.
  explicit MlpEvaluator(std::shared_ptr<const Mlp> mlp);

  const Mlp& mlp() const { return *mlp_; }
  const std::shared_ptr<const Mlp>& shared_mlp() const { return mlp_; }
  int input_size() const { return input_size_; }
  int output_size() const { return output_size_; }

  /// The action for one observation: `observation` holds input_size() values, `action` receives
  /// output_size(). In = double or float, Out = double or float (computed in double, rounded
  /// once at the end for float). InvalidArgument "policy input: observation[i]: expected a
  /// finite number, got nan" for a non-finite observation, and "action[i] is inf: the network
  /// overflows for this observation" for a non-finite result (`action` is then unfinished).
  template <class In, class Out>
  void evaluate(const In* observation, Out* action);

  /// `rows` observations, row-major (rows, input_size()), to `rows` actions, row-major
  /// (rows, output_size()); each row exactly as evaluate() computes it. The message of a
  /// non-finite value names its row: "observations[3, 7]".
  template <class In, class Out>
  void evaluate_rows(const In* observations, std::ptrdiff_t rows, Out* actions);

 private:
  template <class In, class Out>
  void evaluate_row(const In* observation, Out* action, std::ptrdiff_t row);

  std::shared_ptr<const Mlp> mlp_;
  int input_size_ = 0, output_size_ = 0;
  Eigen::VectorXd a_, b_;  // ping-pong workspace, each as wide as the widest layer
};

extern template void MlpEvaluator::evaluate(const double*, double*);
extern template void MlpEvaluator::evaluate(const float*, double*);
extern template void MlpEvaluator::evaluate(const double*, float*);
extern template void MlpEvaluator::evaluate(const float*, float*);
extern template void MlpEvaluator::evaluate_rows(const double*, std::ptrdiff_t, double*);
extern template void MlpEvaluator::evaluate_rows(const float*, std::ptrdiff_t, double*);
extern template void MlpEvaluator::evaluate_rows(const double*, std::ptrdiff_t, float*);
extern template void MlpEvaluator::evaluate_rows(const float*, std::ptrdiff_t, float*);

}  // namespace dronetwin
