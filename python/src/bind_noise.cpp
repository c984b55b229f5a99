// The noise layer's Dryden turbulence (noise/dryden.hpp): its scales, spectra and generated gust
// records as numpy arrays.
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/noise/dryden.hpp"

namespace dronetwin::python {

TurbulenceSeverity severity_from_name(const std::string& name) {
  if (name == "light") return TurbulenceSeverity::kLight;
  if (name == "moderate") return TurbulenceSeverity::kModerate;
  if (name == "severe") return TurbulenceSeverity::kSevere;
  throw InvalidArgument("severity: expected 'light', 'moderate' or 'severe', got '" + name + "'");
}

namespace {

// The scales for a severity name, or for an explicit wind at 20 ft when one is given.
DrydenScales scales_of(double height_m, const std::string& severity,
                       std::optional<double> wind_at_20ft_m_s) {
  return wind_at_20ft_m_s ? dryden_low_altitude(height_m, *wind_at_20ft_m_s)
                          : dryden_low_altitude(height_m, severity_from_name(severity));
}

}  // namespace

void bind_noise(py::module_& m) {
  m.def(
      "dryden_scales",
      [](double height_m, const std::string& severity, std::optional<double> wind_at_20ft_m_s) {
        const DrydenScales s = scales_of(height_m, severity, wind_at_20ft_m_s);
        return py::dict(py::arg("sigma_m_s") = copy_of(s.sigma_m_s),
                        py::arg("length_m") = copy_of(s.length_m));
      },
      py::arg("height_m"), py::arg("severity") = "moderate",
      py::arg("wind_at_20ft_m_s") = py::none(),
      "MIL-F-8785C low-altitude Dryden scales at height_m (clamped to 10 .. 1000 ft): "
      "{'sigma_m_s': (u, v, w), 'length_m': (u, v, w)} for a severity ('light', 'moderate', "
      "'severe': W20 = 15, 30, 45 kt) or an explicit mean wind at 20 ft (m/s).");
  m.def(
      "dryden_psd",
      [](double height_m, double airspeed_m_s, const py::array_t<double>& omega_rad_s,
         const std::string& severity, std::optional<double> wind_at_20ft_m_s) {
        const DrydenScales s = scales_of(height_m, severity, wind_at_20ft_m_s);
        const auto omega = omega_rad_s.unchecked<1>();
        py::array_t<double> out({omega.shape(0), py::ssize_t{3}});
        auto o = out.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < omega.shape(0); ++i) {
          const Vec3 phi = dryden_psd(s, airspeed_m_s, omega(i));
          for (py::ssize_t k = 0; k < 3; ++k) o(i, k) = phi[static_cast<int>(k)];
        }
        return out;
      },
      py::arg("height_m"), py::arg("airspeed_m_s"), py::arg("omega_rad_s"),
      py::arg("severity") = "moderate", py::arg("wind_at_20ft_m_s") = py::none(),
      "One-sided Dryden spectra of u, v, w (m^2/s^2 per rad/s) at the angular frequencies "
      "omega_rad_s (1-D float64 array): shape (n, 3).");
  m.def(
      "dryden_gusts",
      [](double height_m, double airspeed_m_s, double dt_s, std::int64_t steps,
         const std::string& severity, std::optional<double> wind_at_20ft_m_s, std::uint64_t seed,
         bool stationary_start) {
        require(steps >= 0, "dryden_gusts: steps: expected >= 0, got ", steps);
        require(std::isfinite(dt_s) && dt_s > 0.0, "dryden_gusts: dt_s: expected > 0, got ", dt_s);
        require(std::isfinite(airspeed_m_s) && airspeed_m_s >= 0.0,
                "dryden_gusts: airspeed_m_s: expected a number >= 0, got ", airspeed_m_s);
        const DrydenScales s = scales_of(height_m, severity, wind_at_20ft_m_s);
        py::array_t<double> out({static_cast<py::ssize_t>(steps), py::ssize_t{3}});
        double* o = out.mutable_data();
        {
          const py::gil_scoped_release release;
          Random rng(seed);
          DrydenState state = stationary_start ? dryden_start(rng) : DrydenState{};
          for (std::int64_t i = 0; i < steps; ++i) {
            const Vec3 g = dryden_step(state, s, airspeed_m_s, dt_s, rng);
            for (int k = 0; k < 3; ++k) o[3 * i + k] = g[k];
          }
        }
        return out;
      },
      py::arg("height_m"), py::arg("airspeed_m_s"), py::arg("dt_s"), py::arg("steps"),
      py::arg("severity") = "moderate", py::arg("wind_at_20ft_m_s") = py::none(),
      py::arg("seed") = 0, py::arg("stationary_start") = true,
      "A record of Dryden gusts (u along the mean wind, v across, w up; m/s), shape (steps, 3), "
      "at a fixed height and airspeed, one row per step of dt_s; seeded. stationary_start "
      "draws developed turbulence at t = 0 (else it builds up from zero).");
}

}  // namespace dronetwin::python
