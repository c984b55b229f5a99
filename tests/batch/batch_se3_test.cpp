// The batched SE(3) inner loop and the batched allocation against their scalar counterparts: the
// law on a pack equals Se3Controller lane by lane (all option combinations, every tilt branch),
// the batched thrust-first allocation equals allocate(), and a batch flown by BatchSe3Controller
// equals Simulator + Se3Controller + ClosedLoop at the physics rate.

#include "dronetwin/batch/batch_se3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;

std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

std::vector<Se3Options> option_sets() {
  std::vector<Se3Options> sets(7);
  sets[1].gravity_compensation = true;
  sets[2].gravity_compensation = true;
  sets[2].max_tilt_rad = 0.5;
  sets[3].max_tilt_rad = 0.35;
  sets[3].nonnegative_thrust = true;
  sets[4].gravity_compensation = true;
  sets[4].max_tilt_rad = 0.5;
  sets[4].angular_feed_forward = true;
  sets[5].drag_feed_forward = true;
  sets[5].nonnegative_thrust = true;
  sets[6].gravity_compensation = true;
  sets[6].angular_feed_forward = true;
  sets[6].drag_feed_forward = true;
  return sets;
}

StateVector random_state(Random& rng) {
  StateVector x;
  for (int i = 0; i < kStateSize; ++i) x[i] = rng.normal();
  // Unnormalised quaternions, as a noisy measurement gives them.
  x.segment<4>(state_index::kQuaternion) *= 0.5 + rng.uniform();
  return x;
}

ReferencePoint random_reference(Random& rng) {
  ReferencePoint r;
  for (int k = 0; k < 3; ++k) {
    r.position_m[k] = 2.0 * rng.normal();
    r.velocity_m_s[k] = rng.normal();
    // Large accelerations (including downward and level) drive every tilt-cone branch.
    r.acceleration_m_s2[k] = 8.0 * rng.normal();
  }
  r.yaw_rad = 4.0 * rng.normal();
  for (int k = 0; k < 3; ++k) {
    r.jerk_m_s3[k] = 20.0 * rng.normal();
    r.snap_m_s4[k] = 100.0 * rng.normal();
  }
  r.yaw_rate_rad_s = rng.normal();
  r.yaw_acceleration_rad_s2 = 5.0 * rng.normal();
  return r;
}

// The law on a pack of W lanes gives, in every lane, Se3Controller::calculate_u bit for bit.
TEST(BatchSe3, TheLawOnAPackEqualsSe3ControllerInEveryLane) {
  const auto model = test::load_model("qdrone2");
  constexpr int W = kBatchLanes<double>;
  using P = Pack<double, W>;
  Random rng(17);
  for (const Se3Options& options : option_sets()) {
    Se3Controller scalar(model, Se3Gains::thesis(), options);
    for (int round = 0; round < 400; ++round) {
      std::array<ControlInput, W> inputs;
      Se3LawInput<P> in;
      for (int l = 0; l < W; ++l) {
        ControlInput& c = inputs[static_cast<std::size_t>(l)];
        c.state = random_state(rng);
        c.reference = random_reference(rng);
        // Every tenth lane asks for (almost) nothing: the |F| -> 0 guard.
        if (l == round % 10) {
          c.reference.acceleration_m_s2 = Vec3(0, 0, options.gravity_compensation ? -9.81 : 0);
          c.reference.position_m = c.state.segment<3>(kPosition);
          c.reference.velocity_m_s = c.state.segment<3>(state_index::kVelocity);
        }
      }
      const auto lanes = [&](auto&& f) {
        return pack_from<P>([&](int l) { return f(inputs[static_cast<std::size_t>(l)]); });
      };
      for (int k = 0; k < 3; ++k) {
        in.position_m[k] = lanes([&](const ControlInput& c) { return c.state[kPosition + k]; });
        in.velocity_m_s[k] =
            lanes([&](const ControlInput& c) { return c.state[state_index::kVelocity + k]; });
        in.angular_velocity_B[k] = lanes(
            [&](const ControlInput& c) { return c.state[state_index::kAngularVelocity + k]; });
        in.position_ref_m[k] =
            lanes([&](const ControlInput& c) { return c.reference.position_m[k]; });
        in.velocity_ref_m_s[k] =
            lanes([&](const ControlInput& c) { return c.reference.velocity_m_s[k]; });
        in.acceleration_ref_m_s2[k] =
            lanes([&](const ControlInput& c) { return c.reference.acceleration_m_s2[k]; });
      }
      for (int k = 0; k < 4; ++k)
        in.quaternion[k] =
            lanes([&](const ControlInput& c) { return c.state[state_index::kQuaternion + k]; });
      in.cos_yaw = lanes([](const ControlInput& c) { return std::cos(c.reference.yaw_rad); });
      in.sin_yaw = lanes([](const ControlInput& c) { return std::sin(c.reference.yaw_rad); });
      for (int k = 0; k < 3; ++k) {
        // The feed-forward as the batched controller stores it (set_reference, in double).
        const auto ff = [&](const ControlInput& c) {
          return se3_feed_forward(c.reference, *model, scalar.law());
        };
        in.feed_forward.angular_velocity_B[k] =
            lanes([&](const ControlInput& c) { return ff(c).angular_velocity_B[k]; });
        in.feed_forward.angular_acceleration_B[k] =
            lanes([&](const ControlInput& c) { return ff(c).angular_acceleration_B[k]; });
        in.feed_forward.drag_compensation_W[k] =
            lanes([&](const ControlInput& c) { return ff(c).drag_compensation_W[k]; });
      }
      const Vector4<P> u = se3_law<P>(scalar.law(), in);
      for (int l = 0; l < W; ++l) {
        const GeneralizedForce ref = scalar.calculate_u(inputs[static_cast<std::size_t>(l)]);
        for (int k = 0; k < 4; ++k)
          ASSERT_EQ(bits_of(lane(u[k], l)), bits_of(ref[k]))
              << "round " << round << " lane " << l << " component " << k << ": " << lane(u[k], l)
              << " vs " << ref[k];
      }
    }
  }
}

// set_generalized_forces allocates every lane as allocate() does, including saturated requests.
TEST(BatchSe3, BatchedAllocationEqualsTheScalarOneWithItsSaturationFlags) {
  for (const char* name : {"qdrone2", "hexarotor"}) {
    const auto model = test::load_model(name);
    constexpr int N = 203;
    BatchSimulator<double> batch(model, SimConfig{}, N);
    Random rng(4);
    const double weight = model->mass_kg() * 9.81;
    std::vector<double> u(static_cast<std::size_t>(4 * batch.stride()), 0.0);
    std::vector<GeneralizedForce> asked(N);
    for (int l = 0; l < N; ++l) {
      GeneralizedForce& a = asked[static_cast<std::size_t>(l)];
      // Thrust from nothing to far beyond the rotors' range; moments from small to saturating.
      a << weight * 3.0 * rng.uniform(), rng.normal() * (l % 3 == 0 ? 2.0 : 0.05),
          rng.normal() * (l % 3 == 0 ? 2.0 : 0.05), rng.normal() * 0.05;
      for (int k = 0; k < 4; ++k) u[static_cast<std::size_t>(k * batch.stride() + l)] = a[k];
    }
    u[static_cast<std::size_t>(2 * batch.stride() + 5)] = std::nan("");
    batch.set_generalized_forces(u.data());
    int saturated = 0;
    for (int l = 0; l < N; ++l) {
      if (l == 5) {
        EXPECT_EQ(batch.saturated_data()[5], 2) << "a NaN request is flagged, not allocated";
        continue;
      }
      const AllocationResult r = allocate(*model, asked[static_cast<std::size_t>(l)]);
      for (int i = 0; i < model->num_rotors(); ++i)
        ASSERT_EQ(bits_of(batch.rotor_speed_reference_data()[i * batch.stride() + l]),
                  bits_of(r.speeds_rad_s[i]))
            << name << " lane " << l << " rotor " << i;
      EXPECT_EQ(batch.saturated_data()[l], r.saturated ? 1 : 0) << name << " lane " << l;
      saturated += r.saturated;
    }
    EXPECT_GT(saturated, 10) << "the requests exercise saturation";
    EXPECT_LT(saturated, N) << "and the unsaturated path";
  }
}

void fly_batch_and_closed_loop(bool feed_forward);

// In double, a lane flown by BatchSe3Controller equals a Simulator flown by Se3Controller through
// ClosedLoop at the physics rate, over 3 s from tilted, moving starts, with per-lane masses;
// without and with the feed-forward (references with jerk, snap and yaw motion).
TEST(BatchSe3, ALaneFlownByTheBatchedControllerEqualsTheClosedLoop) {
  for (const bool feed_forward : {false, true}) {
    SCOPED_TRACE(feed_forward ? "with feed-forward" : "without feed-forward");
    fly_batch_and_closed_loop(feed_forward);
  }
}

void fly_batch_and_closed_loop(bool feed_forward) {
  const auto model = test::load_model("qdrone2");
  Se3Options options;
  options.gravity_compensation = true;
  options.max_tilt_rad = 0.6;
  options.angular_feed_forward = feed_forward;
  options.drag_feed_forward = feed_forward;
  constexpr int N = 13, kSteps = 3000;
  SimConfig cfg;
  BatchSimulator<double> batch(model, cfg, N, 2);
  BatchSe3Controller<double> se3(model, Se3Gains::thesis(), options, N);
  Random rng(8);
  std::vector<StateVector> starts;
  std::vector<ReferencePoint> refs;
  std::vector<double> masses;
  for (int l = 0; l < N; ++l) {
    StateVector x =
        Simulator::hover_state(Vec3(rng.normal(), rng.normal(), 1.0 + rng.uniform()), rng.normal());
    x.segment<4>(state_index::kQuaternion) += 0.15 * Vec4(0, rng.normal(), rng.normal(), 0);
    x.segment<3>(state_index::kVelocity) = Vec3(rng.normal(), rng.normal(), 0.5 * rng.normal());
    x.segment<3>(state_index::kAngularVelocity) = Vec3(rng.normal(), rng.normal(), rng.normal());
    starts.push_back(x);
    ReferencePoint r;
    r.position_m = Vec3(2.0 * rng.normal(), 2.0 * rng.normal(), 1.0 + rng.uniform());
    r.velocity_m_s = Vec3(0.3 * rng.normal(), 0.3 * rng.normal(), 0.0);
    r.acceleration_m_s2 = Vec3(0.5 * rng.normal(), 0.5 * rng.normal(), 0.0);
    r.yaw_rad = rng.normal();
    r.jerk_m_s3 = Vec3(rng.normal(), rng.normal(), 0.2 * rng.normal());
    r.snap_m_s4 = Vec3(3.0 * rng.normal(), 3.0 * rng.normal(), 0.5 * rng.normal());
    r.yaw_rate_rad_s = 0.2 * rng.normal();
    r.yaw_acceleration_rad_s2 = 0.5 * rng.normal();
    refs.push_back(r);
    masses.push_back(model->mass_kg() * (l % 2 == 0 ? 1.0 : 0.9 + 0.2 * rng.uniform()));
    batch.set_parameter(ModelParameter::kMass, l, masses.back());
    batch.reset(l, x, model->hover_speeds_rad_s());
    se3.set_reference(l, r);
  }
  ASSERT_EQ(batch.step(kSteps, se3), 0);
  double worst = 0.0;
  for (int l = 0; l < N; ++l) {
    VehicleSpec spec = model->spec();
    set_parameter_value(spec, ModelParameter::kMass, masses[static_cast<std::size_t>(l)]);
    Simulator sim(std::make_shared<const VehicleModel>(spec), cfg);
    sim.reset(starts[static_cast<std::size_t>(l)], model->hover_speeds_rad_s());
    Se3Controller scalar(model, Se3Gains::thesis(), options);
    const test::FixedPoint reference(refs[static_cast<std::size_t>(l)]);
    ClosedLoop loop(sim, scalar, reference, 1.0 / cfg.dt_s);
    const StepResult r = loop.run(kSteps * cfg.dt_s);
    ASSERT_TRUE(r.ok()) << "lane " << l;
    const StateVector a = batch.state(l), b = sim.state();
    for (int i = 0; i < kStateSize; ++i)
      worst = std::max(worst, std::abs(a[i] - b[i]) / (1.0 + std::abs(b[i])));
    // Position alone, in metres: the two flights are the same flight.
    EXPECT_LT((a.segment<3>(kPosition) - b.segment<3>(kPosition)).norm(), 1e-9);
  }
  std::printf("[ batch    ] SE(3) batch vs ClosedLoop, 13 lanes x 3 s: worst relative gap %.3g\n",
              worst);
  EXPECT_LE(worst, 1e-12);
}

// In float the batched controller still flies: every lane settles on its setpoint, as the double
// lanes do.
template <class T>
double settle_error(double* yaw_error) {
  const auto model = test::load_model("qdrone2");
  // The flying configuration of config/controllers/se3.yaml: Eq. 3.29 with attitude_d 0.8 in
  // roll and pitch (as printed the lateral motion is lightly damped, notes #36), the gravity
  // term, a 0.5 rad tilt cone and non-negative thrust.
  Se3Gains gains = Se3Gains::thesis();
  gains.attitude_d = Vec3(0.8, 0.8, 0.05);
  Se3Options options;
  options.gravity_compensation = true;
  options.max_tilt_rad = 0.5;
  options.nonnegative_thrust = true;
  constexpr int N = 40;
  BatchSimulator<T> batch(model, SimConfig{}, N);
  BatchSe3Controller<T> se3(model, gains, options, N);
  for (int l = 0; l < N; ++l) {
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
    ReferencePoint r;
    r.position_m = Vec3(0.05 * l - 1.0, 0.5, 1.5);
    r.yaw_rad = 0.1 * l;
    se3.set_reference(l, r);
  }
  EXPECT_EQ(batch.step(10000, se3), 0);
  double worst = 0.0;
  *yaw_error = 0.0;
  for (int l = 0; l < N; ++l) {
    const StateVector x = batch.state(l);
    worst = std::max(worst, (x.segment<3>(kPosition) - Vec3(0.05 * l - 1.0, 0.5, 1.5)).norm());
    const double yaw = math::to_euler(x.segment<4>(state_index::kQuaternion))[2];
    *yaw_error = std::max(*yaw_error, std::abs(std::remainder(yaw - 0.1 * l, 2 * M_PI)));
  }
  return worst;
}

TEST(BatchSe3, FloatLanesSettleOnTheirSetpointsAsDoubleLanesDo) {
  double yaw64 = 0.0, yaw32 = 0.0;
  const double e64 = settle_error<double>(&yaw64);
  const double e32 = settle_error<float>(&yaw32);
  std::printf(
      "[ batch    ] SE(3) after 10 s: worst position error %.3g m (double) %.3g m (float); yaw "
      "%.3g / %.3g rad\n",
      e64, e32, yaw64, yaw32);
  EXPECT_LT(e64, 0.01);
  EXPECT_LT(e32, 0.01);
  EXPECT_LT(yaw64, 0.02);
  EXPECT_LT(yaw32, 0.02);
}

TEST(BatchSe3, BadReferencesAndMismatchedBatchesAreRefusedOrStopTheirLane) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, SimConfig{}, 6);
  BatchSe3Controller<double> se3(model, Se3Gains::thesis(), Se3Options{}, 6);
  BatchSe3Controller<double> other(model, Se3Gains::thesis(), Se3Options{}, 5);
  for (int l = 0; l < 6; ++l)
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
  EXPECT_NE(test::error_of([&] { batch.step(1, other); }).find("inner loop is for 5 vehicles"),
            std::string::npos);
  ReferencePoint bad;
  bad.yaw_rad = std::nan("");
  EXPECT_NE(test::error_of([&] { se3.set_reference(2, bad); }).find("lane 2"), std::string::npos);
  EXPECT_NE(test::error_of([&] { se3.set_reference(6, ReferencePoint{}); }).find("out of range"),
            std::string::npos);
  // With a feed-forward the reference's jerk, snap and yaw derivatives must be finite too.
  Se3Options feed_forward;
  feed_forward.angular_feed_forward = true;
  BatchSe3Controller<double> ff(model, Se3Gains::thesis(), feed_forward, 6);
  ReferencePoint bad_snap;
  bad_snap.snap_m_s4[1] = std::numeric_limits<double>::infinity();
  EXPECT_NE(test::error_of([&] {
              ff.set_reference(3, bad_snap);
            }).find("lane 3: expected finite jerk, snap, yaw rate and yaw acceleration"),
            std::string::npos);
  se3.set_reference(3, bad_snap);  // without a feed-forward they are not read
  // A NaN written into a lane's reference array stops that lane, as a controller failure.
  se3.reference_data()[static_cast<std::size_t>(0 * se3.stride() + 3)] = std::nan("");
  EXPECT_EQ(batch.step(10, se3), 1);
  EXPECT_EQ(batch.status(3), StepStatus::kControllerFailed);
  EXPECT_EQ(batch.step_count(3), 0);
  EXPECT_EQ(batch.step_count(2), 10);
}

}  // namespace
}  // namespace dronetwin
