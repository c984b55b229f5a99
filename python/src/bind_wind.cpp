// The wind field's settings (dynamics/wind_field.hpp): shear, 1 - cos gusts and Dryden
// turbulence around the mean wind, for SimConfig.wind and Simulator.set_wind_field.
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/wind_field.hpp"

namespace dronetwin::python {

void bind_wind(py::module_& m) {
  py::class_<WindShear>(m, "WindShear",
                        "Log-law shear of the mean wind (MIL-F-8785C): W(h) = W_ref ln(h / z0) / "
                        "ln(h_ref / z0), heights below 2 z0 held at 2 z0.")
      .def(py::init([](bool enabled, double reference_height_m, double roughness_length_m) {
             return WindShear{enabled, reference_height_m, roughness_length_m};
           }),
           py::kw_only(), py::arg("enabled") = false, py::arg("reference_height_m") = 6.096,
           py::arg("roughness_length_m") = 0.04572)
      .def_readwrite("enabled", &WindShear::enabled)
      .def_readwrite("reference_height_m", &WindShear::reference_height_m,
                     "Where the mean wind holds (20 ft).")
      .def_readwrite("roughness_length_m", &WindShear::roughness_length_m, "z0 (0.15 ft).");

  py::class_<TurbulenceSettings>(m, "TurbulenceSettings",
                                 "Dryden turbulence (noise/dryden.hpp) along the mean wind's axes.")
      .def(py::init([](bool enabled, double wind_at_20ft_m_s) {
             return TurbulenceSettings{enabled, wind_at_20ft_m_s};
           }),
           py::kw_only(), py::arg("enabled") = false, py::arg("wind_at_20ft_m_s") = 0.0)
      .def_static(
          "of",
          [](const std::string& severity) {
            return TurbulenceSettings::of(severity_from_name(severity));
          },
          py::arg("severity"), "'light', 'moderate' or 'severe' (W20 = 15, 30, 45 kt), on.")
      .def_readwrite("enabled", &TurbulenceSettings::enabled)
      .def_readwrite("wind_at_20ft_m_s", &TurbulenceSettings::wind_at_20ft_m_s,
                     "W20 of the Dryden scales, m/s.");

  py::class_<Gust>(m, "Gust",
                   "A 1 - cos gust: (A / 2) (1 - cos(2 pi (t - start_s) / duration_s)) while it "
                   "lasts, peak A at its middle.")
      .def(py::init([](double start_s, double duration_s, py::handle amplitude) {
             return Gust{start_s, duration_s, to_fixed<3>(amplitude, "Gust.amplitude_W_m_s")};
           }),
           py::arg("start_s"), py::arg("duration_s"), py::arg("amplitude_W_m_s"))
      .def_readwrite("start_s", &Gust::start_s)
      .def_readwrite("duration_s", &Gust::duration_s)
      .def_readwrite("amplitude_W_m_s", &Gust::amplitude_W_m_s, "Peak air velocity, world, m/s.");

  py::class_<WindSettings>(
      m, "WindSettings",
      "Shear, gusts and turbulence around the mean wind (SimConfig.environment.wind_W_m_s).\n\n"
      "    cfg.wind = dronetwin.WindSettings(turbulence=dronetwin.TurbulenceSettings.of('light'),\n"
      "                                      gusts=[dronetwin.Gust(5.0, 2.0, [3, 0, 0])])")
      .def(py::init([](const WindShear& shear, const TurbulenceSettings& turbulence,
                       const std::vector<Gust>& gusts) {
             WindSettings w;
             w.shear = shear;
             w.turbulence = turbulence;
             require(gusts.size() <= static_cast<std::size_t>(kMaxGusts),
                     "WindSettings.gusts: expected at most ", kMaxGusts, " gusts, got ",
                     gusts.size());
             for (std::size_t i = 0; i < gusts.size(); ++i) w.gusts[i] = gusts[i];
             w.num_gusts = static_cast<int>(gusts.size());
             return w;
           }),
           py::kw_only(), py::arg("shear") = WindShear{},
           py::arg("turbulence") = TurbulenceSettings{}, py::arg("gusts") = std::vector<Gust>{})
      .def_readwrite("shear", &WindSettings::shear)
      .def_readwrite("turbulence", &WindSettings::turbulence)
      .def_property(
          "gusts",
          [](const WindSettings& w) {
            return std::vector<Gust>(w.gusts.begin(), w.gusts.begin() + w.num_gusts);
          },
          [](WindSettings& w, const std::vector<Gust>& gusts) {
            require(gusts.size() <= static_cast<std::size_t>(kMaxGusts),
                    "WindSettings.gusts: expected at most ", kMaxGusts, " gusts, got ",
                    gusts.size());
            w.gusts = {};
            for (std::size_t i = 0; i < gusts.size(); ++i) w.gusts[i] = gusts[i];
            w.num_gusts = static_cast<int>(gusts.size());
          },
          "The gusts (a list; assign a new list to change them).")
      .def_property_readonly("varies", &WindSettings::varies,
                             "True when shear, gusts or turbulence are on.");
}

}  // namespace dronetwin::python
