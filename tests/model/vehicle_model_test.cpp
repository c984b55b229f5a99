// Tests of VehicleModel's derived constants (include/dronetwin/model/vehicle_model.hpp). Expected
// values come from the thesis (Eq. 2.22, 2.25, 2.30, Table 2.1) or from hand geometry built here,
// never from the code under test.
#include "dronetwin/model/vehicle_model.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

const std::string kModels = std::string(DRONETWIN_SOURCE_DIR) + "/models/";
constexpr double kPi = 3.141592653589793238462643383;
constexpr double kG = 9.81;

// Thesis Table 2.1 / Eq. 2.22.
constexpr double kLphi = 0.254;     // roll-axis moment arm, m
constexpr double kLtheta = 0.2032;  // pitch-axis moment arm, m
constexpr double kKtau = 68.9055;   // motor torque constant
constexpr double kMass = 1.504;     // kg
constexpr double kK1 = 1.9533e-6;   // 'K1, N s^2/rad^2
constexpr double kK2 = 8.594e-4;    // 'K2 = 0.117 / 136.1356 (thesis-notes #2), N s/rad
constexpr double kK3 = -0.0121;     // 'K3, N

/// Largest |a_ij - b_ij| relative to max(1, |b|_max).
template <class A, class B>
double relative_error(const A& a, const B& b) {
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

// ---- QDrone2 (thesis) -------------------------------------------------------------------------

class QDrone2Model : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = new VehicleModel(load_vehicle_model(kModels + "qdrone2.yaml"));
  }
  static void TearDownTestSuite() {
    delete model_;
    model_ = nullptr;
  }
  static const VehicleModel& m() { return *model_; }

 private:
  static inline const VehicleModel* model_ = nullptr;
};

/// Thesis Eq. 2.30, built from the printed symbols.
Eigen::Matrix4d thesis_allocation() {
  const double a = kLphi / 2, b = kLtheta / 2, k = 1.0 / kKtau;
  Eigen::Matrix4d A;
  A << 1, 1, 1, 1,   //
      -a, -a, a, a,  //
      b, -b, b, -b,  //
      k, -k, -k, k;
  return A;
}

TEST_F(QDrone2Model, AllocationMatrixIsThesisEq230Exactly) {
  // Exact: each entry is y_i, -x_i or +-1/K_tau with the file's 0.127 = 0.254/2, 0.1016 = 0.2032/2
  // (halving is exact in binary) and 1/K_tau written to 17 digits, and the cross product with
  // e3 only multiplies by 0 and 1.
  const Eigen::Matrix4d expected = thesis_allocation();
  ASSERT_EQ(m().allocation_matrix().rows(), 4);
  ASSERT_EQ(m().allocation_matrix().cols(), 4);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(m().allocation_matrix()(r, c), expected(r, c)) << "A(" << r << ", " << c << ")";
}

TEST_F(QDrone2Model, PseudoInverseInvertsAllocation) {
  const Eigen::Matrix4d A = thesis_allocation();
  const Eigen::Matrix4d pinv = m().allocation_pseudo_inverse();
  EXPECT_LT(relative_error(pinv * A, Eigen::Matrix4d::Identity()), 1e-12);
  EXPECT_LT(relative_error(A * pinv, Eigen::Matrix4d::Identity()), 1e-12);
}

TEST_F(QDrone2Model, WrenchMatrixOfParallelRotorsHasRankFourAndZeroLateralRows) {
  EXPECT_EQ(m().wrench_rank(), 4);
  EXPECT_TRUE(m().wrench_matrix().topRows<2>().isZero(0.0));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(m().wrench_matrix()(2, i), 1.0);
}

TEST_F(QDrone2Model, HoverThrustIsQuarterWeightAndSpeedSolvesThrustPolynomial) {
  const double T = kMass * kG / 4;  // 3.68856 N per rotor: the layout is symmetric about the CoM
  const RotorVector thrusts = m().hover_thrusts_N();
  ASSERT_EQ(thrusts.size(), 4);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(thrusts[i], T, 1e-12 * T) << i;

  // Positive root of 'K1 w^2 + 'K2 w + 'K3 = T (thesis Eq. 2.22), textbook quadratic formula.
  const double w_expected = (-kK2 + std::sqrt(kK2 * kK2 - 4 * kK1 * (kK3 - T))) / (2 * kK1);
  const RotorVector speeds = m().hover_speeds_rad_s();
  ASSERT_EQ(speeds.size(), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(speeds[i], w_expected, 1e-9 * w_expected) << i;
    const double w = speeds[i];
    EXPECT_NEAR(kK1 * w * w + kK2 * w + kK3, T, 1e-10) << i;
  }
  // thesis-notes #38 quotes the trim as "1173.5 rad/s"; with g = 9.81 the root is 1173.92 rad/s
  // (1173.68 with g = 9.80665), so the note's value is checked to its apparent rounding only.
  EXPECT_NEAR(w_expected, 1173.5, 0.5);
  // Same note: Eq. 2.31 (dropping 'K2, 'K3) would allocate sqrt(T / 'K1) = 1374.2 rad/s instead.
  EXPECT_NEAR(std::sqrt(T / kK1), 1374.2, 0.05);
}

TEST_F(QDrone2Model, InertiaInverseTimesInertiaIsIdentity) {
  EXPECT_LT(relative_error(m().inertia_inverse() * m().inertia_kgm2(), Mat3::Identity()), 1e-14);
  EXPECT_NEAR(m().inertia_inverse()(0, 0), 1.0 / 0.0147209, 1e-12 / 0.0147209);
}

TEST(VehicleModelDerived, InertiaInverseOfFullMatrix) {
  VehicleSpec spec = load_vehicle_spec(kModels + "qdrone2.yaml");
  // A symmetric, positive-definite tensor with products of inertia (a rotated box).
  spec.inertia_kgm2 << 0.020, -0.001, 0.0005,  //
      -0.001, 0.025, 0.002,                    //
      0.0005, 0.002, 0.035;
  const VehicleModel m(spec);
  EXPECT_LT(relative_error(m.inertia_inverse() * m.inertia_kgm2(), Mat3::Identity()), 1e-13);
  EXPECT_LT(relative_error(m.inertia_kgm2() * m.inertia_inverse(), Mat3::Identity()), 1e-13);
}

// ---- flat hexarotor ---------------------------------------------------------------------------

constexpr double kArm = 0.275;  // models/hexarotor.yaml

/// Hand-built 4 x 6 allocation of the flat hexarotor: rotor k at azimuth 60k deg, spins +-1
/// alternating; column = [1, y_k, -x_k, eps_k / K_tau] (Eq. 2.26 and 2.29 generalised).
Eigen::Matrix<double, 4, 6> hexarotor_allocation() {
  Eigen::Matrix<double, 4, 6> A;
  for (int k = 0; k < 6; ++k) {
    const double th = k * kPi / 3;
    const double eps = k % 2 == 0 ? 1.0 : -1.0;
    A.col(k) << 1.0, kArm * std::sin(th), -kArm * std::cos(th), eps / kKtau;
  }
  return A;
}

TEST(Hexarotor, AllocationMatchesHandGeometry) {
  const VehicleModel m = load_vehicle_model(kModels + "hexarotor.yaml");
  ASSERT_EQ(m.allocation_matrix().cols(), 6);
  EXPECT_LT(relative_error(m.allocation_matrix(), hexarotor_allocation()), 1e-15);
  EXPECT_EQ(m.wrench_rank(), 4);
}

TEST(Hexarotor, ThrustsForReproduceCommandedGeneralizedForces) {
  const VehicleModel m = load_vehicle_model(kModels + "hexarotor.yaml");
  const Eigen::Matrix<double, 4, 6> A = hexarotor_allocation();
  const std::vector<GeneralizedForce> commands = {
      {2.0 * kG, 0, 0, 0}, {25.0, 0.4, -0.3, 0.05}, {0, 1, 0, 0},    {0, 0, 1, 0},
      {0, 0, 0, 1},        {10.0, -2.0, 3.0, -0.2}, {1e-3, 0, 0, 0}, {-5, 0.01, 0.02, 0.03},
  };
  for (const GeneralizedForce& u : commands) {
    const RotorVector t = m.thrusts_for(u);
    ASSERT_EQ(t.size(), 6);
    const Vec4 achieved = A * t;
    EXPECT_LE((achieved - u).norm(), 1e-12 * u.norm()) << "u = " << u.transpose();
  }
  // Hover: six equal thrusts of m g / 6.
  const RotorVector hover = m.hover_thrusts_N();
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(hover[k], 2.0 * kG / 6, 1e-12) << k;
}

// ---- tilted hexarotor -------------------------------------------------------------------------

/// Hand-built 6 x 6 wrench matrix of models/tilted_hexarotor.yaml: axis_k = e3 rotated by
/// +-25 deg about the arm d_k, column = [a_k; r_k x a_k + eps_k a_k / K_tau].
Eigen::Matrix<double, 6, 6> tilted_wrench() {
  const double alpha = 25.0 * kPi / 180.0;
  Eigen::Matrix<double, 6, 6> W;
  for (int k = 0; k < 6; ++k) {
    const double th = k * kPi / 3;
    const double sign = k % 2 == 0 ? 1.0 : -1.0;  // tilt and spin alternate together
    const Vec3 d(std::cos(th), std::sin(th), 0.0);
    const Vec3 r = kArm * d + Vec3(0, 0, 0.03);
    const Vec3 a =
        std::cos(alpha) * Vec3::UnitZ() + std::sin(sign * alpha) * d.cross(Vec3::UnitZ());
    W.col(k) << a, r.cross(a) + sign / kKtau * a;
  }
  return W;
}

TEST(TiltedHexarotor, IsFullyActuated) {
  const VehicleModel m = load_vehicle_model(kModels + "tilted_hexarotor.yaml");
  EXPECT_EQ(m.wrench_rank(), 6);
  EXPECT_LT(relative_error(m.wrench_matrix(), tilted_wrench()), 1e-15);
  // The lateral rows are no longer zero.
  EXPECT_GT(m.wrench_matrix().topRows<2>().cwiseAbs().maxCoeff(), 0.4);
}

TEST(TiltedHexarotor, PseudoInverseReproducesArbitraryWrenches) {
  const VehicleModel m = load_vehicle_model(kModels + "tilted_hexarotor.yaml");
  const Eigen::Matrix<double, 6, 6> W = tilted_wrench();
  using Wrench = Eigen::Matrix<double, 6, 1>;
  std::vector<Wrench> wrenches;
  Wrench w;
  w << 2.0, 0, 0, 0, 0, 0;  // pure lateral force: impossible for a flat multirotor
  wrenches.push_back(w);
  w << 0, -1.5, 0, 0, 0, 0;
  wrenches.push_back(w);
  w << 1.0, -2.0, 2.0 * kG, 0, 0, 0;  // hover while pushing sideways, level
  wrenches.push_back(w);
  w << 0, 0, 0, 0.3, -0.2, 0.1;  // pure moment
  wrenches.push_back(w);
  w << 0.7, 0.3, 15.0, -0.05, 0.08, -0.02;
  wrenches.push_back(w);
  w << -3.0, 4.0, 25.0, 1.0, 1.0, 1.0;
  wrenches.push_back(w);
  for (const Wrench& target : wrenches) {
    const RotorVector t = m.wrench_pseudo_inverse() * target;
    ASSERT_EQ(t.size(), 6);
    const Wrench achieved = W * t;
    EXPECT_LE((achieved - target).norm(), 1e-12 * target.norm())
        << "w = " << target.transpose() << "\nachieved " << achieved.transpose();
  }
  // A pure lateral force needs unequal thrusts that cancel each other's moments, not zero.
  const RotorVector lateral = m.wrench_pseudo_inverse() * wrenches[0];
  EXPECT_GT(lateral.cwiseAbs().maxCoeff(), 0.1);
}

TEST(TiltedHexarotor, HoverThrustsAreEqualAndCompensateTheTilt) {
  const VehicleModel m = load_vehicle_model(kModels + "tilted_hexarotor.yaml");
  const double expected = 2.0 * kG / (6.0 * std::cos(25.0 * kPi / 180.0));  // 3.608 N
  const RotorVector hover = m.hover_thrusts_N();
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(hover[k], expected, 1e-12 * expected) << k;
}

// ---- RotorParams::speed_for_thrust ------------------------------------------------------------

RotorParams qdrone2_rotor() {
  RotorParams r;
  r.thrust_coefficients = {kK1, kK2, kK3};
  r.min_speed_rad_s = 0.0;
  r.max_speed_rad_s = 3400.0;
  return r;
}

TEST(SpeedForThrust, InvertsTheThrustPolynomial) {
  const RotorParams r = qdrone2_rotor();
  for (double w = 0.0; w <= 3400.0; w += 17.0) {
    const double T = kK1 * w * w + kK2 * w + kK3;  // Eq. 2.22 by hand
    EXPECT_DOUBLE_EQ(r.thrust(w), T);
    EXPECT_NEAR(r.speed_for_thrust(T), w, 1e-9 * std::max(1.0, w)) << "w = " << w;
  }
}

TEST(SpeedForThrust, ClampsToTheSpeedLimits) {
  RotorParams r = qdrone2_rotor();
  const double t_max = kK1 * 3400.0 * 3400.0 + kK2 * 3400.0 + kK3;  // 25.49 N
  EXPECT_EQ(r.speed_for_thrust(kK3 - 1.0), 0.0);                    // below T(0) = 'K3
  EXPECT_EQ(r.speed_for_thrust(-100.0), 0.0);
  EXPECT_EQ(r.speed_for_thrust(t_max * 1.01), 3400.0);
  EXPECT_EQ(r.speed_for_thrust(1e9), 3400.0);
  EXPECT_EQ(r.speed_for_thrust(std::numeric_limits<double>::quiet_NaN()), 0.0);

  // A non-zero lower limit: thrust of 50 rad/s maps to the 100 rad/s floor.
  r.min_speed_rad_s = 100.0;
  EXPECT_EQ(r.speed_for_thrust(kK1 * 2500.0 + kK2 * 50.0 + kK3), 100.0);
  EXPECT_NEAR(r.speed_for_thrust(kK1 * 4e4 + kK2 * 200.0 + kK3), 200.0, 1e-9);
}

TEST(SpeedForThrust, LinearCurve) {
  RotorParams r;
  r.thrust_coefficients = {0.0, 0.01, 0.5};
  r.max_speed_rad_s = 1000.0;
  EXPECT_NEAR(r.speed_for_thrust(3.0), 250.0, 1e-12);  // (3 - 0.5) / 0.01
  EXPECT_EQ(r.speed_for_thrust(100.0), 1000.0);
}

// ---- validation of code-built specs -----------------------------------------------------------

TEST(VehicleModelDerived, CodeBuiltSpecErrorsNameTheVehicle) {
  VehicleSpec spec = load_vehicle_spec(kModels + "qdrone2.yaml");
  spec.source.clear();
  spec.name = "my_quad";
  spec.rotors[1].max_speed_rad_s = -1.0;
  try {
    const VehicleModel m(spec);
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("my_quad: rotors[1].max_speed_rad_s", 0), 0u) << e.what();
  }
}

TEST(VehicleModelDerived, AxisIsNormalised) {
  VehicleSpec spec = load_vehicle_spec(kModels + "qdrone2.yaml");
  for (auto& r : spec.rotors) r.axis = Vec3(0, 0, 2.5);
  const VehicleModel m(spec);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(m.rotor(i).axis, Vec3::UnitZ());
  EXPECT_EQ(m.allocation_matrix(),
            VehicleModel(load_vehicle_model(kModels + "qdrone2.yaml")).allocation_matrix());
}

}  // namespace
}  // namespace dronetwin

namespace dronetwin {
namespace {

TEST(VehicleModelTpl, CastKeepsEveryParameterAndTheGeometry) {
  const auto model = test::load_model("tilted_hexarotor");
  const VehicleModelTpl<float> f = model->cast<float>();
  EXPECT_EQ(f.num_rotors(), model->num_rotors());
  EXPECT_EQ(f.mass_kg(), static_cast<float>(model->mass_kg()));
  EXPECT_TRUE(f.inertia_kgm2().isApprox(model->inertia_kgm2().cast<float>()));
  EXPECT_EQ(f.inertia_is_diagonal(), model->inertia_is_diagonal());
  for (int i = 0; i < model->num_rotors(); ++i) {
    EXPECT_EQ(f.rotor(i).spin, model->rotor(i).spin);
    EXPECT_EQ(f.rotor(i).axis, model->rotor(i).axis.cast<float>());
    EXPECT_EQ(f.rotor(i).thrust_coefficients[0],
              static_cast<float>(model->rotor(i).thrust_coefficients[0]));
    EXPECT_EQ(f.rotor(i).max_speed_rad_s, static_cast<float>(model->rotor(i).max_speed_rad_s));
  }
}

TEST(VehicleModelTpl, EditedDerivesTheInverseInertiaAgainAndLeavesTheOriginal) {
  const auto model = test::load_model("qdrone2");
  const VehicleModelTpl<double> heavier = model->edited([](VehicleParametersTpl<double>& p) {
    p.mass_kg *= 1.1;
    p.inertia_kgm2(0, 1) = p.inertia_kgm2(1, 0) = 1e-4;  // no longer principal axes
  });
  EXPECT_DOUBLE_EQ(heavier.mass_kg(), 1.1 * model->mass_kg());
  EXPECT_TRUE((heavier.inertia_kgm2() * heavier.inertia_inverse()).isIdentity(1e-12));
  EXPECT_FALSE(heavier.inertia_is_diagonal());
  EXPECT_TRUE(model->inertia_is_diagonal());
  EXPECT_EQ(model->mass_kg(), model->spec().mass_kg);
}

}  // namespace
}  // namespace dronetwin
