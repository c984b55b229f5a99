// Tests of the vertical thrust-to-mass fit (identification/vertical_fit.hpp) and of the shipped
// models/crazyflie21.yaml: exact recovery on a synthetic log built from the model's own thrust
// curve, the real CrazyPAD flight giving a mass inside the vehicle's documented range, and the
// model hovering inside the rotor-speed range the stand measured.
#include "dronetwin/identification/vertical_fit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "dronetwin/adapters/crazypad_import.hpp"
#include "dronetwin/adapters/thrust_stand_fit.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

const std::string kFlight = test::source_path(
    "tests/data/real/CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv");
const std::string kStand =
    test::source_path("tests/data/real/crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv");

TEST(VerticalFit, RecoversThrustPerMassAndDragExactly) {
  const auto model = test::load_model("crazyflie21");
  const double c = 1.0 / 0.0291, d = 0.37;
  LogTable t;
  t.source = "synthetic";
  t.columns = {"t",  "z",       "vz",      "qw",      "qx",      "qy",
               "qz", "omega_0", "omega_1", "omega_2", "omega_3", "acc_z"};
  Random rng(3);
  for (int i = 0; i < 300; ++i) {
    const Vec4 q = math::from_euler(0.3 * (rng.uniform() - 0.5), 0.3 * (rng.uniform() - 0.5),
                                    6 * rng.uniform());
    double w[4], thrust = 0;
    for (int k = 0; k < 4; ++k) {
      w[k] = 1500 + 700 * rng.uniform();
      thrust += model->rotor(k).thrust(w[k]);
    }
    const double vz = rng.uniform() - 0.5;
    const double r33 = math::rotation_matrix<double>(q)(2, 2);
    const double row[] = {
        0.01 * i, i < 5 ? 0.0 : 0.5,        vz, q[0], q[1], q[2], q[3], w[0], w[1], w[2],
        w[3],     c * r33 * thrust - d * vz};
    t.values.insert(t.values.end(), std::begin(row), std::end(row));
  }
  const VerticalFitResult r = fit_vertical(t, *model);
  EXPECT_EQ(r.num_train + r.num_test, 295u);  // the 5 rows at z = 0 are skipped
  EXPECT_NEAR(r.fit.coefficients[0], c, 1e-9 * c);
  EXPECT_NEAR(r.fit.coefficients[1], d, 1e-9 * d);
  EXPECT_NEAR(r.mass_kg, 0.0291, 1e-12);
  EXPECT_LT(r.rms_test_m_s2, 1e-9);
}

TEST(VerticalFit, RealCrazyPadFlight) {
  const auto model = test::load_model("crazyflie21");
  const ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv(kStand));
  const CrazyPadImport imp = import_crazypad(read_crazypad_csv(kFlight), stand.speed_map);
  LogTable log;
  log.source = "E8_log00";
  log.columns = imp.columns;
  log.values = imp.values;
  VerticalFitOptions o;
  o.prior_mass_kg = 0.031;  // middle of the README's 27-35 g
  const VerticalFitResult r = fit_vertical(log, *model, o);
  // The README: 27-35 g with battery, depending on decks.
  EXPECT_GT(r.mass_kg, 0.027);
  EXPECT_LT(r.mass_kg, 0.035);
  // The fitted model predicts the held-out 30 % better than the README's mid-range mass.
  EXPECT_LT(r.rms_test_m_s2, r.rms_test_prior_m_s2);
  // The shipped model's mass is this fit's (models/crazyflie21.yaml cites it) to 0.1 g.
  EXPECT_NEAR(model->mass_kg(), r.mass_kg, 1e-4);
}

TEST(Crazyflie21Model, LoadsAndHoversInsideTheStandRange) {
  const auto model = test::load_model("crazyflie21");
  const ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv(kStand));
  // The model's thrust curve is the stand fit, to the digits written in the file.
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(model->rotor(0).thrust_coefficients[static_cast<std::size_t>(j)],
                stand.thrust.coefficients[static_cast<std::size_t>(j)],
                1e-5 * std::abs(stand.thrust.coefficients[static_cast<std::size_t>(j)]));
  }
  const RotorVector w = model->hover_speeds_rad_s();
  for (int i = 0; i < 4; ++i) {
    EXPECT_GT(w[i], stand.min_speed_rad_s);
    EXPECT_LT(w[i], stand.max_speed_rad_s);
    EXPECT_NEAR(model->rotor(i).thrust(w[i]), model->mass_kg() * 9.81 / 4, 1e-12);
  }
  // 92 mm motor-to-motor diagonal (README).
  EXPECT_NEAR((model->rotor(0).position_m - model->rotor(2).position_m).norm(), 0.092, 1e-12);
}

}  // namespace
}  // namespace dronetwin
