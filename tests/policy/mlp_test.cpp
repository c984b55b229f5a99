// The policy network (policy/mlp.hpp): a 2-3-2 network evaluated against the function of
// docs/policy-format.md written out by hand, for each activation and output; the float
// overloads and the row-batch helper against the double evaluation; validate()'s messages.
// That an evaluation allocates nothing is checked in tests/sim/no_allocation_test.cpp.

#include "dronetwin/policy/mlp.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/policy/policy.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::error_of;

// W1 [3, 2], b1 [3], W2 [2, 3], b2 [2]; mean, std and clip chosen so that one input is clipped.
Mlp tiny(Mlp::Activation act, Mlp::OutputSquash out) {
  Mlp m;
  m.observation_mean = Eigen::Vector2d(1.0, -2.0);
  m.observation_std = Eigen::Vector2d(2.0, 0.5);
  m.observation_clip = 3.0;
  Eigen::MatrixXd w1(3, 2), w2(2, 3);
  w1 << 0.5, -1.0,  //
      1.5, 0.25,    //
      -0.75, 2.0;
  w2 << 1.0, -0.5, 0.25,  //
      -2.0, 0.125, 1.0;
  m.weights = {w1, w2};
  m.biases = {Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector2d(-0.05, 0.4)};
  m.activation = act;
  m.negative_slope = 0.2;
  m.output = out;
  m.action_scale = Eigen::Vector2d(2.0, 0.5);
  return m;
}

// The function of docs/policy-format.md for tiny(), one multiplication at a time.
std::vector<double> by_hand(Mlp::Activation act, Mlp::OutputSquash out, double o0, double o1) {
  const auto clip = [](double v) { return v < -3.0 ? -3.0 : (v > 3.0 ? 3.0 : v); };
  const double h0 = clip((o0 - 1.0) / 2.0), h1 = clip((o1 + 2.0) / 0.5);
  const auto f = [&](double z) {
    switch (act) {
      case Mlp::Activation::kLeakyRelu:
        return z > 0 ? z : 0.2 * z;
      case Mlp::Activation::kRelu:
        return z > 0 ? z : 0.0;
      case Mlp::Activation::kTanh:
        return std::tanh(z);
    }
    return z;
  };
  const double g0 = f(0.5 * h0 - 1.0 * h1 + 0.1);
  const double g1 = f(1.5 * h0 + 0.25 * h1 - 0.2);
  const double g2 = f(-0.75 * h0 + 2.0 * h1 + 0.3);
  const double z0 = 1.0 * g0 - 0.5 * g1 + 0.25 * g2 - 0.05;
  const double z1 = -2.0 * g0 + 0.125 * g1 + 1.0 * g2 + 0.4;
  const auto s = [&](double z) { return out == Mlp::OutputSquash::kTanh ? std::tanh(z) : z; };
  return {2.0 * s(z0), 0.5 * s(z1)};
}

struct Combo {
  Mlp::Activation act;
  Mlp::OutputSquash out;
};

TEST(Mlp, MatchesTheFunctionWrittenOutByHandForEachActivationAndOutput) {
  const Combo combos[] = {{Mlp::Activation::kLeakyRelu, Mlp::OutputSquash::kTanh},
                          {Mlp::Activation::kLeakyRelu, Mlp::OutputSquash::kIdentity},
                          {Mlp::Activation::kRelu, Mlp::OutputSquash::kTanh},
                          {Mlp::Activation::kRelu, Mlp::OutputSquash::kIdentity},
                          {Mlp::Activation::kTanh, Mlp::OutputSquash::kTanh},
                          {Mlp::Activation::kTanh, Mlp::OutputSquash::kIdentity}};
  // Observations that put hidden units on both sides of zero, and one clipped at +3 (o1 = 5
  // normalises to 14) and one at -3.
  const double observations[][2] = {{0.0, 0.0}, {3.0, -2.5}, {-4.0, 1.0}, {1.0, 5.0}, {9.0, -9.0}};
  for (const Combo& c : combos) {
    MlpEvaluator e(std::make_shared<const Mlp>(tiny(c.act, c.out)));
    EXPECT_EQ(e.input_size(), 2);
    EXPECT_EQ(e.output_size(), 2);
    for (const auto& o : observations) {
      double a[2];
      e.evaluate(o, a);
      const std::vector<double> want = by_hand(c.act, c.out, o[0], o[1]);
      EXPECT_NEAR(a[0], want[0], 1e-15) << static_cast<int>(c.act) << static_cast<int>(c.out);
      EXPECT_NEAR(a[1], want[1], 1e-15) << static_cast<int>(c.act) << static_cast<int>(c.out);
    }
  }
}

TEST(Mlp, HandValuesSpotCheck) {
  // One case worked on paper: leaky_relu, tanh, o = (3, -2.5): h = (1, -1);
  // g = f(1.6, 1.05, -2.45) = (1.6, 1.05, -0.49); z = (0.9025, -3.15875);
  // a = (2 tanh(0.9025), 0.5 tanh(-3.15875)).
  MlpEvaluator e(
      std::make_shared<const Mlp>(tiny(Mlp::Activation::kLeakyRelu, Mlp::OutputSquash::kTanh)));
  const double o[2] = {3.0, -2.5};
  double a[2];
  e.evaluate(o, a);
  EXPECT_NEAR(a[0], 2.0 * std::tanh(0.9025), 1e-14);
  EXPECT_NEAR(a[1], 0.5 * std::tanh(-3.15875), 1e-14);
}

TEST(Mlp, FloatOverloadsAndRowsAgreeWithTheDoubleEvaluation) {
  MlpEvaluator e(
      std::make_shared<const Mlp>(tiny(Mlp::Activation::kTanh, Mlp::OutputSquash::kTanh)));
  Random rng(7);
  const int n = 50;
  std::vector<float> obs_f(2 * n);
  std::vector<double> obs_d(2 * n);
  for (int i = 0; i < 2 * n; ++i) {
    obs_f[i] = static_cast<float>(8 * rng.uniform() - 4);
    obs_d[i] = obs_f[i];  // the same numbers in both precisions
  }
  std::vector<double> rows_d(2 * n), rows_fd(2 * n);
  std::vector<float> rows_ff(2 * n);
  e.evaluate_rows(obs_d.data(), n, rows_d.data());
  e.evaluate_rows(obs_f.data(), n, rows_fd.data());
  e.evaluate_rows(obs_f.data(), n, rows_ff.data());
  for (int r = 0; r < n; ++r) {
    double one[2];
    float one_f[2];
    e.evaluate(&obs_d[2 * r], one);
    e.evaluate(&obs_d[2 * r], one_f);
    for (int k = 0; k < 2; ++k) {
      EXPECT_EQ(rows_d[2 * r + k], one[k]);  // bitwise: the same computation
      EXPECT_EQ(rows_fd[2 * r + k], one[k]);
      EXPECT_EQ(rows_ff[2 * r + k], static_cast<float>(one[k]));
      EXPECT_EQ(one_f[k], static_cast<float>(one[k]));
    }
  }
}

TEST(Mlp, DeeperNetworkUsesEveryLayerInOrder) {
  // 1 -> 1 -> 1 -> 1 with identity-like layers: the output is tanh of a chain of affine maps.
  Mlp m;
  m.observation_mean = Eigen::VectorXd::Zero(1);
  m.observation_std = Eigen::VectorXd::Ones(1);
  for (const double w : {2.0, 3.0, 0.5}) {
    m.weights.push_back(Eigen::MatrixXd::Constant(1, 1, w));
    m.biases.push_back(Eigen::VectorXd::Constant(1, 1.0));
  }
  m.activation = Mlp::Activation::kRelu;
  m.output = Mlp::OutputSquash::kIdentity;
  m.action_scale = Eigen::VectorXd::Constant(1, 3.0);
  EXPECT_EQ(m.layer_widths(), (std::vector<int>{1, 1, 1, 1}));
  MlpEvaluator e(std::make_shared<const Mlp>(m));
  const double o = 0.5;
  double a = 0;
  e.evaluate(&o, &a);
  EXPECT_DOUBLE_EQ(a, 3.0 * (0.5 * (3.0 * (2.0 * 0.5 + 1.0) + 1.0) + 1.0));
}

TEST(Mlp, NonFiniteObservationsAreRefusedByPosition) {
  MlpEvaluator e(
      std::make_shared<const Mlp>(tiny(Mlp::Activation::kTanh, Mlp::OutputSquash::kTanh)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double o[2] = {0.0, nan};
  double a[2];
  EXPECT_EQ(error_of([&] { e.evaluate(o, a); }),
            "MlpEvaluator: observation[1]: expected a finite number, got nan");
  const double rows[4] = {0.0, 0.0, std::numeric_limits<double>::infinity(), 0.0};
  double out[4];
  EXPECT_EQ(error_of([&] { e.evaluate_rows(rows, 2, out); }),
            "MlpEvaluator: observations[1, 0]: expected a finite number, got inf");
}

TEST(Mlp, ValidateNamesTheFieldAndWhatWasExpected) {
  const auto good = [] { return tiny(Mlp::Activation::kLeakyRelu, Mlp::OutputSquash::kTanh); };
  EXPECT_NO_THROW(validate(good()));
  struct Case {
    void (*edit)(Mlp&);
    const char* message;
  };
  const Case cases[] = {
      {[](Mlp& m) { m.weights.clear(); }, "mlp: weights: expected at least one layer, got none"},
      {[](Mlp& m) { m.biases.pop_back(); }, "mlp: biases: expected 2 (one per layer), got 1"},
      {[](Mlp& m) { m.weights[1] = Eigen::MatrixXd::Zero(2, 4); },
       "mlp: weights[1]: expected 3 columns (the rows of weights[0]), got 4"},
      {[](Mlp& m) { m.biases[0] = Eigen::VectorXd::Zero(2); },
       "mlp: biases[0]: expected 3 entries (the rows of weights[0]), got 2"},
      {[](Mlp& m) { m.weights[0](2, 1) = std::nan(""); },
       "mlp: weights[0]: expected finite numbers, entry [2, 1] is nan"},
      {[](Mlp& m) { m.biases[1][1] = HUGE_VAL; },
       "mlp: biases[1]: expected finite numbers, entry [1] is inf"},
      {[](Mlp& m) { m.observation_mean = Eigen::VectorXd::Zero(3); },
       "mlp: observation_mean: expected 2 entries (the input size), got 3"},
      {[](Mlp& m) { m.observation_std[1] = 0.0; },
       "mlp: observation_std: expected finite numbers > 0, entry [1] is 0"},
      {[](Mlp& m) { m.observation_clip = -1.0; },
       "mlp: observation_clip: expected a finite number > 0, got -1"},
      {[](Mlp& m) { m.action_scale = Eigen::VectorXd::Ones(3); },
       "mlp: action_scale: expected 2 entries (the output size), got 3"},
      {[](Mlp& m) { m.activation = static_cast<Mlp::Activation>(7); },
       "mlp: activation: expected leaky_relu, relu or tanh, got the value 7"},
      {[](Mlp& m) { m.output = static_cast<Mlp::OutputSquash>(5); },
       "mlp: output: expected tanh or identity, got the value 5"},
      {[](Mlp& m) { m.negative_slope = std::nan(""); },
       "mlp: negative_slope: expected a finite number, got nan"},
  };
  for (const Case& c : cases) {
    Mlp m = good();
    c.edit(m);
    EXPECT_EQ(error_of([&] { validate(m); }), c.message);
    EXPECT_EQ(error_of([&] { MlpEvaluator e(std::make_shared<const Mlp>(m)); }), c.message);
  }
  EXPECT_EQ(error_of([] { MlpEvaluator e(nullptr); }),
            "MlpEvaluator: expected a network, got a null pointer");
}

TEST(Policy, RequireEnvMatchNamesTheFirstDifference) {
  PolicyFile p;
  p.mlp = tiny(Mlp::Activation::kLeakyRelu, Mlp::OutputSquash::kTanh);
  p.observation = {{"position", 1}, {"velocity", 1}};
  p.observation_size = 2;
  p.action_size = 2;
  p.action_mode = "ctbr";
  p.normalized_actions = true;
  p.source = "hover.dtpolicy";
  EXPECT_NO_THROW(validate(p));
  using rl::ObservationPiece;
  const std::vector<rl::PieceSlice> same = {{ObservationPiece::kPosition, 0, 1},
                                            {ObservationPiece::kVelocity, 1, 1}};
  EXPECT_NO_THROW(require_env_match(p, same, rl::ActionMode::kCtbr, true, 2));
  const std::vector<rl::PieceSlice> other = {{ObservationPiece::kPosition, 0, 1},
                                             {ObservationPiece::kBodyRates, 1, 1}};
  EXPECT_EQ(error_of([&] { require_env_match(p, other, rl::ActionMode::kCtbr, true, 2); }),
            "hover.dtpolicy: observation[1]: the policy was trained on velocity (1), the env "
            "observes body_rates (1)");
  EXPECT_EQ(error_of([&] { require_env_match(p, {same[0]}, rl::ActionMode::kCtbr, true, 2); }),
            "hover.dtpolicy: observation[1]: the policy was trained on velocity (1), the env "
            "observes nothing");
  EXPECT_EQ(error_of([&] { require_env_match(p, same, rl::ActionMode::kRotorSpeeds, true, 2); }),
            "hover.dtpolicy: action_mode: the policy was trained with \"ctbr\", the env uses "
            "\"rotor_speeds\"");
  EXPECT_EQ(error_of([&] { require_env_match(p, same, rl::ActionMode::kCtbr, false, 2); }),
            "hover.dtpolicy: normalized_actions: the policy was trained with true, the env uses "
            "false");

  PolicyFile bad = p;
  bad.observation[1].size = 2;
  EXPECT_EQ(error_of([&] { validate(bad); }),
            "hover.dtpolicy: observation: the piece sizes sum to 3, observation_size is 2");
  bad = p;
  bad.action_mode = "thrust";
  EXPECT_EQ(error_of([&] { validate(bad); }),
            "hover.dtpolicy: action_mode: expected one of relative_position, global_position, "
            "rotor_speeds, ctbr, generalized_force, got \"thrust\"");
  bad = p;
  bad.mlp.observation_clip = 0;
  EXPECT_EQ(error_of([&] { validate(bad); }),
            "hover.dtpolicy: mlp: observation_clip: expected a finite number > 0, got 0");
}

}  // namespace
}  // namespace dronetwin
