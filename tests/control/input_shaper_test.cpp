// Input shaping against a slung payload's swing (control/input_shaper.hpp): the modes are roots of
// the pair's characteristic polynomial, written out by hand; the ZV shapers' impulses sum to one
// and their transform vanishes at every mode (no residual oscillation); the SE(3) controller
// builds them from its own gains.

#include <gtest/gtest.h>

#include <complex>

#include "dronetwin/control/input_shaper.hpp"
#include "dronetwin/control/se3.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kVehicleKg = 1.504, kPayloadKg = 0.5, kTetherM = 0.5, kG = 9.81;
constexpr double kP = 33.5757, kD = 5.7746;  // Eq. 3.29, x axis

TEST(InputShaper, TheModesAreRootsOfThePairsCharacteristicPolynomial) {
  const SwingModes modes = slung_payload_swing_modes(kVehicleKg, kPayloadKg, kTetherM, kG, kP, kD);
  ASSERT_EQ(modes.count, 2);
  // (m s^2 + K_d s + K_p)(s^2 + g / l) + (m_L g / l) s^2 = 0, from the Laplace transforms of
  // m x'' = -K_p x - K_d x' + (m_L g / l) x_r and x_r'' = -(g / l) x_r - x''.
  for (const std::complex<double>& s : modes.poles) {
    const std::complex<double> p = (kVehicleKg * s * s + kD * s + kP) * (s * s + kG / kTetherM) +
                                   (kPayloadKg * kG / kTetherM) * s * s;
    EXPECT_LT(std::abs(p), 1e-10 * kVehicleKg * std::pow(std::abs(s), 4)) << s;
    EXPECT_LT(s.real(), 0.0);  // the loop alone is stable, only lightly damped
  }
}

TEST(InputShaper, TheShaperLeavesNoResidualOscillationOfEitherMode) {
  const SwingModes modes = slung_payload_swing_modes(kVehicleKg, kPayloadKg, kTetherM, kG, kP, kD);
  const InputShaper shaper = zv_shaper(modes);
  ASSERT_EQ(shaper.count, 4);
  double sum = 0.0;
  for (int k = 0; k < shaper.count; ++k) {
    EXPECT_GT(shaper.impulses[static_cast<std::size_t>(k)].amplitude, 0.0);
    sum += shaper.impulses[static_cast<std::size_t>(k)].amplitude;
  }
  EXPECT_NEAR(sum, 1.0, 1e-15);  // a step still ends where it was going
  // The impulse train's Laplace transform sum a_k exp(-s d_k) vanishes at each mode: the
  // oscillations the impulses start cancel.
  for (const std::complex<double>& s : modes.poles) {
    std::complex<double> v = 0.0;
    for (int k = 0; k < shaper.count; ++k) {
      const ShaperImpulse& i = shaper.impulses[static_cast<std::size_t>(k)];
      v += i.amplitude * std::exp(-s * i.delay_s);
    }
    EXPECT_LT(std::abs(v), 1e-12) << s;
  }
}

TEST(InputShaper, TheSe3ControllerShapesWithItsOwnGainsAndNeedsThePayload) {
  const auto model = test::load_model("qdrone2");
  Se3Gains gains = Se3Gains::thesis();
  Se3Options options;
  options.payload_mass_kg = kPayloadKg;
  options.payload_tether_length_m = kTetherM;
  options.shape_reference_for_payload = true;
  const Se3Controller se3(model, gains, options);
  for (int axis = 0; axis < 2; ++axis) {
    const InputShaper expected =
        zv_shaper(slung_payload_swing_modes(gains.mass_kg, kPayloadKg, kTetherM, gains.gravity_m_s2,
                                            gains.position_p[axis], gains.position_d[axis]));
    const InputShaper& got = se3.shapers()[static_cast<std::size_t>(axis)];
    ASSERT_EQ(got.count, expected.count);
    for (int k = 0; k < got.count; ++k)
      EXPECT_EQ(got.impulses[static_cast<std::size_t>(k)].delay_s,
                expected.impulses[static_cast<std::size_t>(k)].delay_s);
  }
  options.payload_tether_length_m = 0.0;
  const auto error = [&] {
    return test::error_of([&] { Se3Controller bad(model, gains, options); });
  };
  EXPECT_EQ(error(),
            "se3_geometric: shape_reference_for_payload needs payload_tether_length_m > 0, got 0");
  options.payload_tether_length_m = kTetherM;
  options.payload_mass_kg = 0.0;
  EXPECT_EQ(error(), "se3_geometric: shape_reference_for_payload needs payload_mass_kg > 0, got 0");
  options.payload_mass_kg = -1.0;
  EXPECT_EQ(error(), "se3_geometric: payload_mass_kg: expected a mass >= 0, got -1");
}

}  // namespace
}  // namespace dronetwin
