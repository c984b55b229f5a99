// The force kernel (dynamics/force_kernel.hpp) against an independent term-by-term evaluation of
// thesis Eq. 2.22-2.42 written out in this file, for every combination of switches, at random
// states, on a quad, a hexa and a tilted-rotor layout; its per-term breakdown against the same
// terms; and the kernel instantiated with float, ceres::Jet and SIMD packs against double.

#include "dronetwin/dynamics/force_kernel.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/core/simd.hpp"
#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

// ---- the oracle: every term as the thesis writes it, one rotor at a time -----------------------

struct Oracle {
  WrenchBreakdown terms;
  Vec3 force_B = Vec3::Zero(), moment_B = Vec3::Zero();
  void add(Term t, const Vec3& force_B_at, const Vec3& at_B, const Vec3& pure_moment_B) {
    terms[t].force_B += force_B_at;
    terms[t].moment_B += at_B.cross(force_B_at) + pure_moment_B;
    force_B += force_B_at;
    moment_B += at_B.cross(force_B_at) + pure_moment_B;
  }
};

Oracle oracle_wrench(const VehicleModel& m, const DisturbanceSwitches& sw, const Environment& env,
                     const StateVector& x, const RotorVector& speeds) {
  Oracle o;
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(6));
  const Vec3 v_air_B = R.transpose() * (x.segment<3>(3) - env.wind_W_m_s);
  const Vec3 w_B = x.segment<3>(10);
  Vec3 momentum = Vec3::Zero();
  for (int i = 0; i < m.num_rotors(); ++i) {
    const RotorParams& r = m.rotor(i);
    const double w = speeds[i];
    const auto& c = r.thrust_coefficients;
    const double T = c[0] * w * w + c[1] * w + c[2];                        // Eq. 2.22
    o.add(Term::kThrust, T * r.axis, r.position_m, Vec3::Zero());           // Eq. 2.27
    const Vec3 reaction = r.spin * T * r.yaw_moment_per_thrust_m * r.axis;  // Eq. 2.24
    o.add(Term::kYawReaction, Vec3::Zero(), r.position_m, reaction);
    const Vec3 v_hub = v_air_B + w_B.cross(r.position_m);  // Eq. 2.33
    const Vec3 v_perp = v_hub - r.axis.dot(v_hub) * r.axis;
    if (sw.rotor_drag) {  // Eq. 2.32
      o.add(Term::kRotorDrag, -std::abs(w) * r.rotor_drag_coefficient * v_perp, r.position_m,
            Vec3::Zero());
    }
    if (sw.rolling_moment) {
      o.add(Term::kRollingMoment, Vec3::Zero(), r.position_m,
            std::abs(w) * r.rolling_moment_coefficient * v_perp);
    }
    if (sw.drag_moment) {
      o.add(Term::kDragMoment, Vec3::Zero(), r.position_m,
            -r.spin * r.drag_moment_coefficient * T * r.axis);
    }
    if (sw.ground_effect) {  // appendix C.2
      const double h = std::max(x[2] + (R * r.position_m).z(), m.ground_effect_min_height_m());
      o.add(Term::kGroundEffect, r.ground_effect_coefficient * T / (h * h) * r.axis, r.position_m,
            Vec3::Zero());
    }
    momentum += r.spin * r.inertia_kgm2 * w * r.axis;
  }
  if (sw.gyroscopic) o.add(Term::kGyroscopic, Vec3::Zero(), Vec3::Zero(), -w_B.cross(momentum));
  if (sw.body_drag) {
    o.add(Term::kBodyDrag, -(m.body_drag_Ns_per_m() * v_air_B), Vec3::Zero(), Vec3::Zero());
  }
  return o;
}

StateVector oracle_derivative(const VehicleModel& m, const DisturbanceSwitches& sw,
                              const Environment& env, const StateVector& x,
                              const RotorVector& speeds) {
  const Oracle o = oracle_wrench(m, sw, env, x, speeds);
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(6));
  const Vec3 w = x.segment<3>(10);
  StateVector d;
  d.segment<3>(0) = x.segment<3>(3);
  d.segment<3>(3) = R * o.force_B / m.mass_kg() + env.gravity_W_m_s2;  // Eq. 2.41
  const Vec4 q = x.segment<4>(6);
  Vec4 omega(0, w[0], w[1], w[2]);
  d.segment<4>(6) = 0.5 * math::multiply<double>(q, omega);  // Eq. 2.13
  d.segment<3>(10) =
      m.inertia_kgm2().inverse() * (o.moment_B - w.cross(m.inertia_kgm2() * w));  // Eq. 2.42
  return d;
}

DisturbanceSwitches switches_from_bits(int bits) {
  return {(bits & 1) != 0, (bits & 2) != 0,  (bits & 4) != 0,
          (bits & 8) != 0, (bits & 16) != 0, (bits & 32) != 0};
}

RotorVector random_speeds(const VehicleModel& m, Random& rng) {
  RotorVector w(m.num_rotors());
  for (int i = 0; i < m.num_rotors(); ++i) w[i] = 3000.0 * rng.uniform();
  return w;
}

class ForceKernelTest : public ::testing::TestWithParam<const char*> {};

TEST_P(ForceKernelTest, EqualsTheTermByTermModelForEverySwitchCombination) {
  const auto model = test::load_model(GetParam());
  Random rng(7);
  Environment env;
  for (int bits = 0; bits < 64; ++bits) {
    const DisturbanceSwitches sw = switches_from_bits(bits);
    const ForceKernel<double> kernel(*model, ForceTerms::of(sw));
    HeldRotorTerms<double> held;
    for (int trial = 0; trial < 5; ++trial) {
      // Low states too, so the ground-effect floor is exercised.
      const StateVector x = test::random_state(rng, 0.0, 1.0);
      const RotorVector w = random_speeds(*model, rng);
      env.wind_W_m_s << rng.uniform() - 0.5, rng.uniform() - 0.5, 0.2 * rng.uniform();
      kernel.prepare(w, held);
      const StateVector got = kernel.derivative(held, x, env);
      const StateVector expected = oracle_derivative(*model, sw, env, x, w);
      EXPECT_LT((got - expected).norm(), 1e-12 * (1.0 + expected.norm())) << "switches " << bits;
    }
  }
}

TEST_P(ForceKernelTest, BreakdownGivesEachTermAndSumsToTheKernelsWrench) {
  const auto model = test::load_model(GetParam());
  Random rng(3);
  Environment env;
  env.wind_W_m_s = Vec3(1.0, -0.4, 0.2);
  for (int bits : {0, 63, 21, 42}) {
    const DisturbanceSwitches sw = switches_from_bits(bits);
    for (int trial = 0; trial < 5; ++trial) {
      const StateVector x = test::random_state(rng, 0.0, 0.6);
      const RotorVector w = random_speeds(*model, rng);
      const WrenchBreakdown b = wrench_breakdown(*model, sw, env, x, w);
      const Oracle o = oracle_wrench(*model, sw, env, x, w);
      for (int t = 0; t + 1 < kNumTerms; ++t) {  // gravity is checked in rotor_test
        const Term term = static_cast<Term>(t);
        const Wrench<double>& got = b[term];
        const Wrench<double>& want = o.terms[term];
        const double scale = 1.0 + want.force_B.norm() + want.moment_B.norm();
        EXPECT_LT((got.force_B - want.force_B).norm(), 1e-12 * scale) << term_name(term);
        EXPECT_LT((got.moment_B - want.moment_B).norm(), 1e-12 * scale) << term_name(term);
      }
      // The terms (without gravity) add up to what the simulator integrates.
      const ForceKernel<double> kernel(*model, ForceTerms::of(sw));
      HeldRotorTerms<double> held;
      kernel.prepare(w, held);
      const Mat3 R = math::rotation_matrix<double>(x.segment<4>(6));
      const Vector6<double> total = kernel.wrench(held, x, R, env.wind_W_m_s);
      Wrench<double> sum = b.total();
      sum.force_B -= b[Term::kGravity].force_B;
      EXPECT_LT((sum.force_B - total.head<3>()).norm(), 1e-12 * (1.0 + total.norm()));
      EXPECT_LT((sum.moment_B - total.tail<3>()).norm(), 1e-12 * (1.0 + total.norm()));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Models, ForceKernelTest,
                         ::testing::Values("qdrone2", "hexarotor", "tilted_hexarotor"));

// ---- one kernel, many scalars ---------------------------------------------------------------

TEST(ForceKernelScalars, FloatAgreesWithDoubleToSinglePrecision) {
  const auto model = test::load_model("qdrone2");
  const VehicleModelTpl<float> model_f = model->cast<float>();
  const ForceKernel<double> kd(*model, ForceTerms{});
  const ForceKernel<float> kf(model_f, ForceTerms{});
  Random rng(19);
  for (int trial = 0; trial < 20; ++trial) {
    const StateVector x = test::random_state(rng, 0.0, 1.0);
    const RotorVector w = random_speeds(*model, rng);
    HeldRotorTerms<double> hd;
    HeldRotorTerms<float> hf;
    kd.prepare(w, hd);
    std::array<float, kMaxRotors> wf{};
    for (int i = 0; i < w.size(); ++i) wf[static_cast<std::size_t>(i)] = static_cast<float>(w[i]);
    kf.prepare(wf, hf);
    const Vec3 wind(0.5, -0.2, 0.0), g(0, 0, -9.81);
    const StateVector d = kd.derivative(hd, x, wind, g);
    const StateVectorT<float> xf = x.cast<float>();
    const StateVectorT<float> f =
        kf.derivative(hf, xf, Vector3<float>(wind.cast<float>()), Vector3<float>(g.cast<float>()));
    // The accelerations are differences of O(10) m/s^2 terms: a few float ulps of those.
    for (int i = 0; i < kStateSize; ++i)
      EXPECT_NEAR(f[i], d[i], 2e-5 * (1.0 + std::abs(d[i]) + d.norm())) << i;
  }
}

TEST(ForceKernelScalars, JetStateDerivativesEqualCentralDifferences) {
  const auto model = test::load_model("tilted_hexarotor");
  using J = ceres::Jet<double, kStateSize>;
  const ForceKernel<J> kj(model->cast<J>(), ForceTerms{});
  const ForceKernel<double> kd(*model, ForceTerms{});
  Random rng(23);
  const StateVector x = test::random_state(rng, 0.02, 0.2);  // near the ground: C_G matters
  const RotorVector w = random_speeds(*model, rng);
  const Environment env;
  HeldRotorTerms<J> hj;
  HeldRotorTerms<double> hd;
  kj.prepare(w, hj);
  kd.prepare(w, hd);
  StateVectorT<J> xj;
  for (int i = 0; i < kStateSize; ++i) xj[i] = J(x[i], i);
  const StateVectorT<J> dj = kj.derivative(hj, xj, env);
  const StateVector d0 = kd.derivative(hd, x, env);
  for (int j = 0; j < kStateSize; ++j) {
    const double h = 1e-6;
    StateVector xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    const StateVector numeric =
        (kd.derivative(hd, xp, env) - kd.derivative(hd, xm, env)) / (2.0 * h);
    for (int i = 0; i < kStateSize; ++i) {
      EXPECT_EQ(dj[i].a, d0[i]) << i;  // the value part is the double computation
      EXPECT_NEAR(dj[i].v[j], numeric[i], 1e-6 * (1.0 + std::abs(numeric[i])))
          << "d x_dot[" << i << "] / d x[" << j << "]";
    }
  }
}

TEST(ForceKernelScalars, EachLaneOfAPackIsItsOwnVehicle) {
  // Four different vehicles (mass, inertia, thrust curve, drag and wind per lane) stepped as one
  // pack: every lane equals the double kernel on that lane's own model.
  const auto base = test::load_model("qdrone2");
  constexpr int W = 4;
  using P = Pack<double, W>;
  std::array<VehicleModelTpl<double>, W> lanes{*base, *base, *base, *base};
  for (int l = 0; l < W; ++l) {
    const double f = 1.0 + 0.05 * l;
    lanes[static_cast<std::size_t>(l)] = base->edited([&](VehicleParametersTpl<double>& p) {
      p.mass_kg *= f;
      p.inertia_kgm2.diagonal() *= 2.0 - f;
      p.body_drag_Ns_per_m *= f * f;
      for (int i = 0; i < p.num_rotors; ++i) {
        p.rotors[static_cast<std::size_t>(i)].thrust_coefficients[0] *= f;
        p.rotors[static_cast<std::size_t>(i)].rotor_drag_coefficient /= f;
        p.rotors[static_cast<std::size_t>(i)].yaw_moment_per_thrust_m *= 2.0 - f;
      }
    });
  }
  // The pack model: the base cast to packs, each per-lane parameter gathered from the lanes.
  const VehicleModelTpl<P> packed = base->cast<P>().edited([&](VehicleParametersTpl<P>& p) {
    const auto gather = [&](auto get) {
      return pack_from<P>([&](int l) { return get(lanes[static_cast<std::size_t>(l)]); });
    };
    p.mass_kg = gather([](const auto& m) { return m.mass_kg(); });
    for (int a = 0; a < 3; ++a) {
      p.inertia_kgm2(a, a) = gather([a](const auto& m) { return m.inertia_kgm2()(a, a); });
      for (int b = 0; b < 3; ++b) {
        p.body_drag_Ns_per_m(a, b) =
            gather([a, b](const auto& m) { return m.body_drag_Ns_per_m()(a, b); });
      }
    }
    for (int i = 0; i < p.num_rotors; ++i) {
      auto& r = p.rotors[static_cast<std::size_t>(i)];
      r.thrust_coefficients[0] =
          gather([i](const auto& m) { return m.rotor(i).thrust_coefficients[0]; });
      r.rotor_drag_coefficient =
          gather([i](const auto& m) { return m.rotor(i).rotor_drag_coefficient; });
      r.yaw_moment_per_thrust_m =
          gather([i](const auto& m) { return m.rotor(i).yaw_moment_per_thrust_m; });
    }
  });
  const ForceKernel<P> kp(packed, ForceTerms{});
  Random rng(29);
  std::array<StateVector, W> x;
  std::array<RotorVector, W> w;
  std::array<Vec3, W> wind;
  for (int l = 0; l < W; ++l) {
    x[static_cast<std::size_t>(l)] = test::random_state(rng, 0.0, 0.5);
    w[static_cast<std::size_t>(l)] = random_speeds(*base, rng);
    wind[static_cast<std::size_t>(l)] = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0);
  }
  StateVectorT<P> xp;
  Vector3<P> wind_p;
  std::array<P, kMaxRotors> w_p{};
  for (int i = 0; i < kStateSize; ++i)
    xp[i] = pack_from<P>([&](int l) { return x[static_cast<std::size_t>(l)][i]; });
  for (int a = 0; a < 3; ++a)
    wind_p[a] = pack_from<P>([&](int l) { return wind[static_cast<std::size_t>(l)][a]; });
  for (int i = 0; i < base->num_rotors(); ++i)
    w_p[static_cast<std::size_t>(i)] =
        pack_from<P>([&](int l) { return w[static_cast<std::size_t>(l)][i]; });
  HeldRotorTerms<P> hp;
  kp.prepare(w_p, hp);
  const StateVectorT<P> dp = kp.derivative(hp, xp, wind_p, Vec3(0, 0, -9.81));
  for (int l = 0; l < W; ++l) {
    const auto k = static_cast<std::size_t>(l);
    const ForceKernel<double> kd(lanes[k], ForceTerms{});
    HeldRotorTerms<double> hd;
    kd.prepare(w[k], hd);
    const StateVector d = kd.derivative(hd, x[k], wind[k], Vec3(0, 0, -9.81));
    for (int i = 0; i < kStateSize; ++i)
      EXPECT_NEAR(lane(dp[i], l), d[i], 1e-14 * (1.0 + std::abs(d[i]))) << "lane " << l << " " << i;
  }
}

TEST(ForceKernelScalars, AFloatPackEqualsTheFloatKernelLaneByLane) {
  // The single-precision batch instantiates the kernel on float packs: each lane is the float
  // kernel on that lane's state (same operations in the same order; only a fused multiply-add
  // the compiler may form differently tells them apart, hence a few float ulps).
  const auto model = test::load_model("tilted_hexarotor");
  constexpr int W = 8;
  using P = Pack<float, W>;
  const ForceKernel<P> kp(model->cast<P>(), ForceTerms{});
  const ForceKernel<float> kf(model->cast<float>(), ForceTerms{});
  Random rng(31);
  std::array<StateVectorT<float>, W> x;
  std::array<std::array<float, kMaxRotors>, W> w{};
  StateVectorT<P> xp;
  std::array<P, kMaxRotors> wp{};
  for (int l = 0; l < W; ++l) {
    const auto k = static_cast<std::size_t>(l);
    x[k] = test::random_state(rng, 0.02, 0.5).cast<float>();
    const RotorVector speeds = random_speeds(*model, rng);
    for (int i = 0; i < model->num_rotors(); ++i)
      w[k][static_cast<std::size_t>(i)] = static_cast<float>(speeds[i]);
  }
  for (int i = 0; i < kStateSize; ++i)
    xp[i] = pack_from<P>([&](int l) { return x[static_cast<std::size_t>(l)][i]; });
  for (int i = 0; i < model->num_rotors(); ++i)
    wp[static_cast<std::size_t>(i)] = pack_from<P>(
        [&](int l) { return w[static_cast<std::size_t>(l)][static_cast<std::size_t>(i)]; });
  const Vector3<float> wind(0.5f, -0.2f, 0.0f), g(0.0f, 0.0f, -9.81f);
  HeldRotorTerms<P> hp;
  kp.prepare(wp, hp);
  const StateVectorT<P> dp = kp.derivative(hp, xp, wind, g);
  for (int l = 0; l < W; ++l) {
    const auto k = static_cast<std::size_t>(l);
    HeldRotorTerms<float> hf;
    kf.prepare(w[k], hf);
    const StateVectorT<float> d = kf.derivative(hf, x[k], wind, g);
    for (int i = 0; i < kStateSize; ++i)
      EXPECT_NEAR(lane(dp[i], l), d[i], 1e-5f * (1.0f + std::abs(d[i])))
          << "lane " << l << " " << i;
  }
}

}  // namespace
}  // namespace dronetwin
