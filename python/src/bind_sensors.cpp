// Sensors (sensors/): the SensorSuite that samples a Simulator's motion at each sensor's rate and
// latency, the depth camera with numpy frames, the Allan deviation and the ISA atmosphere.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/core/single_thread.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/allan_deviation.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin::python {

namespace {

/// A SensorSuite fed from a Simulator: remembers the state of the previous update (the truth's
/// accelerations in ground contact come from the step's change of velocity).
struct PySensorSuite {
  PySensorSuite(std::vector<SensorSpec> specs, double physics_dt_s, int rotors, std::uint64_t seed)
      : suite(std::move(specs), physics_dt_s, rotors, seed),
        dt_s(physics_dt_s),
        num_rotors(rotors),
        seed_now(seed) {}

  void update(const Simulator& sim, const Track* scene) {
    require(std::abs(sim.config().dt_s - dt_s) <= 1e-12 * dt_s,
            "SensorSuite.update: the simulator's dt_s ", sim.config().dt_s,
            " differs from the suite's ", dt_s);
    require(sim.model().num_rotors() == num_rotors, "SensorSuite.update: the simulator has ",
            sim.model().num_rotors(), " rotors, the suite was made for ", num_rotors);
    const std::int64_t step = sim.step_count();
    require(step == next_step || step == 0, "SensorSuite.update: expected step ", next_step,
            " (one update per physics step, in order), got step ", step,
            " (a simulator back at step 0 restarts the sensors)");
    if (step == 0 && next_step != 0) reset_streams();
    const StateVector previous = step == 0 ? sim.state() : previous_state;
    suite.update(step, make_sensor_truth(sim, previous, scene));
    previous_state = sim.state();
    next_step = step + 1;
  }
  void reset_streams() {
    suite.reset(seed_now);
    next_step = 0;
  }
  int index(const std::string& name) const {
    for (int i = 0; i < suite.size(); ++i)
      if (suite.specs()[static_cast<std::size_t>(i)].name == name) return i;
    std::string names;
    for (const SensorSpec& s : suite.specs()) names += (names.empty() ? "" : ", ") + s.name;
    throw InvalidArgument(detail::concat("no sensor named '", name, "' (sensors: ", names, ")"));
  }

  SensorSuite suite;
  double dt_s;
  int num_rotors;
  std::uint64_t seed_now;
  std::int64_t next_step = 0;
  StateVector previous_state = StateVector::Zero();
  SingleThreadGuard guard;
};

py::array_t<double> reading_values(const SensorReading& r) {
  py::array_t<double> a(r.size);
  std::copy(r.values.begin(), r.values.begin() + r.size, a.mutable_data());
  return a;
}

py::array_t<double> state_rows(py::handle obj, const char* what) {
  if (!py::isinstance<py::array>(obj) ||
      !py::array(py::reinterpret_borrow<py::object>(obj)).dtype().is(py::dtype::of<double>()))
    throw py::type_error(std::string(what) +
                         ": expected a float64 numpy array of shape (N, 13), got " +
                         describe_object(obj));
  auto a = py::reinterpret_borrow<py::array>(obj);
  if (a.ndim() != 2 || a.shape(1) != kStateSize)
    throw py::value_error(std::string(what) + ": expected shape (N, 13), got " +
                          describe_object(obj));
  return py::array_t<double, py::array::c_style | py::array::forcecast>(a);
}

}  // namespace

void bind_sensors(py::module_& m) {
  py::class_<PySensorSuite>(
      m, "SensorSuite",
      "The sensors on a vehicle (docs/sensors.md): each samples the simulator's true motion at "
      "its\n"
      "own rate and delivers after its latency, with seeded noise.\n\n"
      "    sensors = dronetwin.SensorSuite([{'type': 'imu'}, {'type': 'gps', 'rate_hz': 5}],\n"
      "                                    dt_s=sim.config.dt_s, num_rotors=4, seed=1)\n"
      "    sensors.update(sim)                 # at step 0, then after every sim.step()\n"
      "    log = sensors.run(sim, 1000)        # or: step 1000 times, every delivery as arrays\n"
      "    stamp, f_w = sensors.latest('imu')  # the latest delivered reading\n\n"
      "Specs are dicts with the keys of an experiment file's `sensors:` list "
      "(docs/experiment-format.md); errors name the entry and field (ValueError).")
      .def(py::init([](const py::list& specs, double dt_s, int num_rotors, std::uint64_t seed) {
             const std::string text =
                 py::module_::import("json").attr("dumps")(specs).cast<std::string>();
             auto s = std::make_unique<PySensorSuite>(parse_sensor_specs(text, "sensors", dt_s),
                                                      dt_s, num_rotors, seed);
             return s;
           }),
           py::arg("specs"), py::arg("dt_s"), py::arg("num_rotors"), py::arg("seed") = 0)
      .def_property_readonly("names",
                             [](const PySensorSuite& s) {
                               py::list out;
                               for (const SensorSpec& sp : s.suite.specs()) out.append(sp.name);
                               return out;
                             })
      .def(
          "channels",
          [](const PySensorSuite& s, const std::string& name) {
            const SensorSpec& sp = s.suite.specs()[static_cast<std::size_t>(s.index(name))];
            py::list out;
            for (const SensorChannel& c : sensor_channels(sp, s.num_rotors))
              out.append(py::make_tuple(name + "_" + c.suffix, c.unit, c.meaning));
            return out;
          },
          py::arg("name"), "The (log column, unit, meaning) of each value of sensor `name`.")
      .def(
          "reset",
          [](PySensorSuite& s, std::optional<std::uint64_t> seed) {
            const auto hold = SingleThreadGuard::Hold(s.guard, "SensorSuite.reset");
            if (seed) s.seed_now = *seed;
            s.reset_streams();
          },
          py::arg("seed") = py::none(),
          "Restarts the streams (and redraws the biases) for a run from step 0.")
      .def(
          "update",
          [](PySensorSuite& s, const Simulator& sim, const Track* scene) {
            const auto hold = SingleThreadGuard::Hold(s.guard, "SensorSuite.update");
            s.update(sim, scene);
          },
          py::arg("sim"), py::arg("scene") = nullptr,
          "Samples what is due at the simulator's current step (call at step 0 and after every "
          "step); `scene` (a Track) adds obstacles to the ground for range finders and flow.")
      .def(
          "latest",
          [](const PySensorSuite& s, const std::string& name) {
            const int i = s.index(name);
            const SensorReading& r = s.suite.latest(i);
            return py::make_tuple(r.stamp_s, reading_values(r));
          },
          py::arg("name"),
          "(stamp_s, values) of the latest delivered reading of `name` (NaN before the first).")
      .def(
          "run",
          [](PySensorSuite& s, Simulator& sim, std::int64_t steps, const Track* scene) {
            require(steps >= 0, "SensorSuite.run: steps: expected >= 0, got ", steps);
            const auto hold = SingleThreadGuard::Hold(s.guard, "SensorSuite.run");
            const int count = s.suite.size();
            std::vector<std::vector<double>> stamps(static_cast<std::size_t>(count)),
                values(static_cast<std::size_t>(count));
            std::vector<std::size_t> width(static_cast<std::size_t>(count));
            for (int i = 0; i < count; ++i)
              width[static_cast<std::size_t>(i)] = static_cast<std::size_t>(s.suite.latest(i).size);
            const auto collect = [&] {
              for (int i = 0; i < count; ++i) {
                if (!s.suite.fresh(i)) continue;
                const auto u = static_cast<std::size_t>(i);
                const SensorReading& r = s.suite.latest(i);
                stamps[u].push_back(r.stamp_s);
                values[u].insert(values[u].end(), r.values.begin(),
                                 r.values.begin() + static_cast<std::ptrdiff_t>(width[u]));
              }
            };
            {
              const py::gil_scoped_release release;
              // A simulator at step 0 is sampled there first; update() restarts the streams if
              // anything was sampled before, so sampling step 0 again repeats its readings.
              if (sim.step_count() == 0) {
                s.update(sim, scene);
                collect();
              }
              for (std::int64_t k = 0; k < steps; ++k) {
                const StepResult r = sim.step();
                if (!r.ok()) break;
                s.update(sim, scene);
                collect();
              }
            }
            py::dict out;
            for (int i = 0; i < count; ++i) {
              const auto u = static_cast<std::size_t>(i);
              const auto rows = static_cast<py::ssize_t>(stamps[u].size());
              py::array_t<double> t(rows), v({rows, static_cast<py::ssize_t>(width[u])});
              std::copy(stamps[u].begin(), stamps[u].end(), t.mutable_data());
              std::copy(values[u].begin(), values[u].end(), v.mutable_data());
              out[py::str(s.suite.specs()[u].name)] = py::make_tuple(t, v);
            }
            return out;
          },
          py::arg("sim"), py::arg("steps"), py::arg("scene") = nullptr,
          "Steps the simulator `steps` times (as it is actuated: set its references first), "
          "updating the sensors (and at step 0 first if nothing was sampled yet). Returns "
          "{name: (stamps (K,), values (K, channels))} of every delivery, in order. Stops early "
          "if the simulator fails (its status says why). Releases the GIL.");

  py::class_<DepthCamera>(
      m, "DepthCamera",
      "Pinhole depth camera by ray casting (docs/sensors.md): depth = the optical-axis "
      "coordinate, max_range_m where nothing is hit. Mounted at the centre of mass looking "
      "along body x unless `mounting_rpy_deg` / `mounting_position_m` say otherwise (optical "
      "frame: z forward, x right, y down, then rotated by the roll-pitch-yaw about the body).")
      .def(
          py::init([](int width_px, int height_px, double fov_deg, double max_range_m,
                      double noise_at_1m_m, double rate_hz, py::object position,
                      py::object rpy_deg) {
            DepthCameraParameters p;
            p.width_px = width_px;
            p.height_px = height_px;
            p.horizontal_fov_deg = fov_deg;
            p.max_range_m = max_range_m;
            p.noise_at_1m_m = noise_at_1m_m;
            p.rate_hz = rate_hz;
            if (!position.is_none())
              p.mounting.position_B_m = to_fixed<3>(position, "DepthCamera: mounting_position_m");
            if (!rpy_deg.is_none()) {
              const Vec3 a = to_fixed<3>(rpy_deg, "DepthCamera: mounting_rpy_deg") * (M_PI / 180.0);
              const Mounting fwd = DepthCameraParameters::forward_looking();
              p.mounting.rotation_BS_wxyz =
                  math::multiply<double>(math::from_euler(a[0], a[1], a[2]), fwd.rotation_BS_wxyz);
            }
            return DepthCamera(p);
          }),
          py::arg("width_px") = 64, py::arg("height_px") = 48, py::arg("horizontal_fov_deg") = 90.0,
          py::arg("max_range_m") = 20.0, py::arg("noise_at_1m_m") = 0.0, py::arg("rate_hz") = 30.0,
          py::arg("mounting_position_m") = py::none(), py::arg("mounting_rpy_deg") = py::none())
      .def_property_readonly("shape",
                             [](const DepthCamera& c) {
                               return py::make_tuple(c.parameters().height_px,
                                                     c.parameters().width_px);
                             })
      .def_property_readonly("focal_px", &DepthCamera::focal_px)
      .def(
          "render",
          [](const DepthCamera& c, py::handle states, const Track* scene, std::uint64_t seed) {
            const py::array_t<double> x = state_rows(states, "DepthCamera.render: states");
            const auto n = static_cast<std::size_t>(x.shape(0));
            for (std::size_t i = 0; i < n; ++i)
              for (int j = 0; j < kStateSize; ++j)
                require(std::isfinite(x.data()[i * kStateSize + static_cast<std::size_t>(j)]),
                        "DepthCamera.render: states[", i, ", ", j, "] is not finite");
            py::array_t<float> out({static_cast<py::ssize_t>(n),
                                    static_cast<py::ssize_t>(c.parameters().height_px),
                                    static_cast<py::ssize_t>(c.parameters().width_px)});
            Random rng(seed);
            {
              const py::gil_scoped_release release;
              c.render_batch(x.data(), n, scene, out.mutable_data(), &rng);
            }
            return out;
          },
          py::arg("states"), py::arg("scene") = nullptr, py::arg("seed") = 0,
          "Frames of N vehicles: states (N, 13) float64 -> depths (N, height, width) float32, m "
          "(row 0 at the top). `scene` a Track, or None for the ground alone. Releases the GIL.");

  m.def(
      "allan_deviation",
      [](py::array_t<double, py::array::c_style | py::array::forcecast> samples, double dt_s,
         std::optional<std::vector<std::int64_t>> cluster_sizes) {
        require(samples.ndim() == 1, "allan_deviation: samples: expected a 1-D array, got ",
                samples.ndim(), " dimensions");
        const std::span<const double> y(samples.data(), static_cast<std::size_t>(samples.shape(0)));
        const std::vector<std::int64_t> m_sizes =
            cluster_sizes ? *cluster_sizes
                          : log_spaced_cluster_sizes(static_cast<std::int64_t>(y.size()), 10);
        std::vector<AllanPoint> pts;
        {
          const py::gil_scoped_release release;
          pts = allan_deviation(y, dt_s, m_sizes);
        }
        py::array_t<double> tau(static_cast<py::ssize_t>(pts.size())),
            dev(static_cast<py::ssize_t>(pts.size()));
        py::array_t<std::int64_t> windows(static_cast<py::ssize_t>(pts.size()));
        for (std::size_t i = 0; i < pts.size(); ++i) {
          tau.mutable_data()[i] = pts[i].tau_s;
          dev.mutable_data()[i] = pts[i].deviation;
          windows.mutable_data()[i] = pts[i].windows;
        }
        py::dict out;
        out["tau_s"] = tau;
        out["deviation"] = dev;
        out["windows"] = windows;
        return out;
      },
      py::arg("samples"), py::arg("dt_s"), py::arg("cluster_sizes") = py::none(),
      "Overlapping Allan deviation of a uniformly sampled signal (IEEE Std 952). Returns "
      "{'tau_s', 'deviation', 'windows'} arrays; cluster sizes default to 10 per decade.");
  m.def("isa_pressure_Pa", &isa_pressure_Pa, py::arg("altitude_m"),
        "ISA static pressure at an altitude above mean sea level, Pa.");
  m.def("isa_altitude_m", &isa_altitude_m, py::arg("pressure_Pa"),
        "ISA altitude of a static pressure, m.");
}

}  // namespace dronetwin::python
