// Bindings of the RL environments (rl/vec_env.hpp): VecEnv64 / VecEnv32 (physics in float64 or
// float32), made from an environment file plus overrides. The Python front end is
// python/dronetwin/rl.py (make, spaces, info dicts); these are its engine.
//
// Every output is a read-only numpy view onto the env's buffers (no copy; the view keeps the env
// alive). Observations alternate between two buffers, so a view stays valid until the step after
// next (rl.py copies where gymnasium's conventions need a fresh array).

#include <pybind11/pybind11.h>

#include <algorithm>
#include <memory>
#include <string>

#include "bindings.hpp"
#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/rl/vec_env.hpp"

namespace dronetwin::python {

namespace {

template <class T>
py::array_t<T> rows_view(const T* data, py::ssize_t rows, py::ssize_t columns, py::handle owner) {
  const auto item = static_cast<py::ssize_t>(sizeof(T));
  py::array_t<T> a({rows, columns}, {columns * item, item}, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

template <class T>
py::array_t<T> flat_view(const T* data, py::ssize_t n, py::handle owner) {
  py::array_t<T> a({n}, {static_cast<py::ssize_t>(sizeof(T))}, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array bool_view(const std::uint8_t* data, py::ssize_t n, py::handle owner) {
  // uint8 holding 0 / 1, seen as numpy bool (same size, valid values only).
  py::array a(py::dtype("bool"), {n}, {py::ssize_t{1}}, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

/// A (rows, columns) numpy copy of row-major doubles (buffers the next step rewrites).
py::array_t<double> copy_rows(const double* data, int rows, int columns) {
  py::array_t<double> out({static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(columns)});
  std::copy(data, data + static_cast<std::size_t>(rows) * static_cast<std::size_t>(columns),
            out.mutable_data());
  return out;
}

template <class T>
void bind_vec_env(py::module_& m, const char* name) {
  using E = rl::VecEnv<T>;
  py::class_<E>(m, name,
                "num_envs RL environments on the batched engine (rl/vec_env.hpp); use "
                "dronetwin.rl.make rather than this class")
      .def(py::init([](const std::string& path, const std::string& overrides, int num_envs,
                       int num_threads) {
             EnvFile f = load_env_config(path, overrides);
             return std::make_unique<E>(f.model, f.config, num_envs, num_threads);
           }),
           py::arg("path"), py::arg("overrides") = "", py::arg("num_envs") = 1,
           py::arg("num_threads") = 1)
      .def_property_readonly("num_envs", &E::num_envs)
      .def_property_readonly("action_size", &E::action_size)
      .def_property_readonly("observation_size", &E::observation_size)
      .def_property_readonly("substeps", &E::substeps)
      .def_property_readonly("control_dt_s", &E::control_dt_s)
      .def_property_readonly("vehicle_radius_m", &E::vehicle_radius_m)
      .def_property_readonly("collision_shape", &E::collision_shape,
                             "What touches gates and obstacles (CollisionShape).")
      .def_property_readonly("observation_float32", &E::observation_float32)
      .def_property_readonly("normalized_actions",
                             [](const E& e) { return e.config().normalized_actions; })
      .def_property_readonly("episode_time_s", [](const E& e) { return e.config().episode_time_s; })
      .def_property_readonly(
          "task",
          [](const E& e) { return std::string(rl::kTaskNames[static_cast<int>(e.config().task)]); })
      .def_property_readonly(
          "action_mode",
          [](const E& e) {
            return std::string(rl::kActionModeNames[static_cast<int>(e.config().action)]);
          })
      .def_property_readonly("action_low", &E::action_low)
      .def_property_readonly("action_high", &E::action_high)
      .def_property_readonly("observation_low", &E::observation_low)
      .def_property_readonly("observation_high", &E::observation_high)
      .def_property_readonly(
          "observation_layout",
          [](const E& e) {
            py::list out;
            for (const rl::PieceSlice& s : e.observation_layout())
              out.append(
                  py::make_tuple(std::string(rl::kObservationPieceNames[static_cast<int>(s.piece)]),
                                 s.offset, s.size));
            for (const rl::SensorSlice& s : e.sensor_slices())
              out.append(
                  py::make_tuple((s.depth ? "depth:" : "sensor:") + s.name, s.offset, s.size));
            return out;
          },
          "(name, offset, size) of each part of an observation row: the pieces, then each "
          "sensor ('sensor:<name>': its channels and a flag, 1 when they hold a reading) and "
          "depth camera ('depth:<name>': height x width depths, m).")
      .def_property_readonly(
          "gates",
          [](const E& e) {
            // (num_gates, 4, 3) opening corners and the centres, for plots.
            const Track& t = e.config().track;
            py::array_t<double> corners(
                {static_cast<py::ssize_t>(t.gates.size()), py::ssize_t{4}, py::ssize_t{3}});
            auto c = corners.mutable_unchecked<3>();
            for (std::size_t g = 0; g < t.gates.size(); ++g) {
              const auto k = t.gates[g].corners();
              for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 3; ++j)
                  c(static_cast<py::ssize_t>(g), i, j) = k[static_cast<std::size_t>(i)][j];
            }
            return corners;
          })
      .def(
          "reset", [](E& e, std::uint64_t seed) { e.reset(seed); }, py::arg("seed"),
          "Every env starts a new episode; env i draws from stream (seed, i).")
      .def(
          "reset_env",
          [](E& e, int env, py::handle state) {
            if (state.is_none())
              e.reset_env(env);
            else
              e.reset_env(env, to_fixed<kStateSize>(state, "reset_env: state"));
          },
          py::arg("env"), py::arg("state") = py::none(),
          "Env `env` starts a new episode, at `state` (13 values) or at the task's random start.")
      .def(
          "step",
          [](E& e, py::handle actions) {
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            const auto k = static_cast<py::ssize_t>(e.action_size());
            py::array a = py::array::ensure(actions);
            if (!a)
              throw py::type_error("step: actions: expected a numeric array, got " +
                                   describe_object(actions));
            const char kind = a.dtype().kind();
            if (kind != 'f' && kind != 'i' && kind != 'u')
              throw py::type_error("step: actions: expected a float array, got dtype " +
                                   std::string(py::str(a.dtype())));
            const bool flat_one = n == 1 && a.ndim() == 1 && a.shape(0) == k;
            if (!flat_one && (a.ndim() != 2 || a.shape(0) != n || a.shape(1) != k))
              throw py::value_error("step: actions: expected shape (" + std::to_string(n) + ", " +
                                    std::to_string(k) + ") (num_envs, action_size), got " +
                                    describe_object(actions));
            if (a.dtype().is(py::dtype::of<float>())) {
              auto f = py::array_t<float, py::array::c_style>::ensure(a);
              const float* p = f.data();
              py::gil_scoped_release release;
              e.step(p);
            } else {
              auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
              const double* p = d.data();
              py::gil_scoped_release release;
              e.step(p);
            }
          },
          py::arg("actions"), "One env step for every env (GIL released).")
      .def(
          "set_overrides",
          [](E& e, const std::string& path, const std::string& overrides) {
            EnvFile f = load_env_config(path, overrides);
            e.set_config(f.config);
          },
          py::arg("path"), py::arg("overrides"),
          "Re-reads the env file with new overrides and applies what may change between resets "
          "(randomisation, reward weights, limits, track, start).")
      .def(
          "observation",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            const auto k = static_cast<py::ssize_t>(e.observation_size());
            if (e.observation_float32())
              return py::array(rows_view(e.template observation<float>(), n, k, self));
            return py::array(rows_view(e.template observation<double>(), n, k, self));
          },
          "(num_envs, observation_size) read-only view of the newest observations.")
      .def(
          "final_observation",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            const auto k = static_cast<py::ssize_t>(e.observation_size());
            if (e.observation_float32())
              return py::array(rows_view(e.template final_observation<float>(), n, k, self));
            return py::array(rows_view(e.template final_observation<double>(), n, k, self));
          },
          "(num_envs, observation_size) read-only view: last observation of the episodes that "
          "ended in the last step (rows where done()).")
      .def(
          "reward",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            return flat_view(e.reward_data(), e.num_envs(), self);
          },
          "(num_envs,) read-only view of the last step's rewards.")
      .def(
          "reward_terms",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            py::dict out;
            for (int k = 0; k < rl::kNumRewardTerms; ++k)
              out[py::str(std::string(rl::kRewardTermNames[static_cast<std::size_t>(k)]))] =
                  flat_view(e.reward_terms_data() + static_cast<std::size_t>(k) * e.num_envs(),
                            e.num_envs(), self);
            return out;
          },
          "Dict term name -> (num_envs,) read-only view of that weighted reward term (Eq. 4.20).")
      .def(
          "terminated",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            return bool_view(e.terminated_data(), e.num_envs(), self);
          },
          "(num_envs,) bool view: the episode ended in a terminal state (crash, flip, invalid "
          "action, finished).")
      .def(
          "truncated",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            return bool_view(e.truncated_data(), e.num_envs(), self);
          },
          "(num_envs,) bool view: the episode hit the time limit.")
      .def(
          "done",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            return bool_view(e.done_data(), e.num_envs(), self);
          },
          "(num_envs,) bool view: terminated or truncated (the env was reset in the last step).")
      .def(
          "end_cause",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            return flat_view(e.end_cause_data(), e.num_envs(), self);
          },
          "(num_envs,) uint8 view: why each episode ended (index into END_CAUSES; 0 = running).")
      .def(
          "finished",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            py::dict out;
            out["return"] = flat_view(e.finished_return_data(), n, self);
            out["length"] = flat_view(e.finished_length_data(), n, self);
            out["gates"] = flat_view(e.finished_gates_data(), n, self);
            out["laps"] = flat_view(e.finished_laps_data(), n, self);
            out["best_lap_s"] = flat_view(e.finished_best_lap_data(), n, self);
            return out;
          },
          "Dict of (num_envs,) views with the statistics of the episodes that ended in the last "
          "step: return, length, gates, laps, best_lap_s.")
      .def(
          "running",
          [](py::object self) {
            const E& e = self.cast<const E&>();
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            py::dict out;
            out["return"] = flat_view(e.episode_return_data(), n, self);
            out["length"] = flat_view(e.episode_length_data(), n, self);
            out["gates"] = flat_view(e.gates_passed_data(), n, self);
            out["laps"] = flat_view(e.laps_data(), n, self);
            out["next_gate"] = flat_view(e.next_gate_data(), n, self);
            out["episode"] = flat_view(e.episode_index_data(), n, self);
            return out;
          },
          "Dict of (num_envs,) views of the running episodes: return, length, gates, laps, "
          "next_gate, episode.")
      .def(
          "state",
          [](const E& e) {
            // (num_envs, 13) copy of the true states.
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            py::array_t<double> out({n, static_cast<py::ssize_t>(kStateSize)});
            auto o = out.mutable_unchecked<2>();
            for (int l = 0; l < e.num_envs(); ++l)
              for (int k = 0; k < kStateSize; ++k)
                o(l, k) = static_cast<double>(e.batch().state_at(k, l));
            return out;
          },
          "(num_envs, 13) copy of the true vehicle states.")
      .def_property_readonly(
          "track", [](const E& e) { return std::make_shared<Track>(e.config().track); },
          "The env's track (racing: its gates; every task: the obstacles of its scene), a copy.")
      .def_property_readonly(
          "rotor_positions_m",
          [](const E& e) {
            const int r = e.model().num_rotors();
            py::array_t<double> out({static_cast<py::ssize_t>(r), py::ssize_t{3}});
            auto o = out.mutable_unchecked<2>();
            for (int i = 0; i < r; ++i)
              for (int k = 0; k < 3; ++k) o(i, k) = e.model().rotor(i).position_m[k];
            return out;
          },
          "(num_rotors, 3) hub positions of the env's airframe, body frame, m.")
      .def(
          "rotor_speeds",
          [](const E& e) {
            const auto n = static_cast<py::ssize_t>(e.num_envs());
            const int r = e.model().num_rotors();
            py::array_t<double> out({n, static_cast<py::ssize_t>(r)});
            auto o = out.mutable_unchecked<2>();
            for (int l = 0; l < e.num_envs(); ++l) {
              const RotorVector omega = e.batch().rotor_speeds(l);
              for (int k = 0; k < r; ++k) o(l, k) = omega[k];
            }
            return out;
          },
          "(num_envs, num_rotors) copy of the achieved rotor speeds, rad/s.")
      .def(
          "final_state",
          [](const E& e) { return copy_rows(e.final_state_data(), e.num_envs(), kStateSize); },
          "(num_envs, 13) copy of the state each ended episode reached (valid where done).")
      .def(
          "final_rotor_speeds",
          [](const E& e) {
            return copy_rows(e.final_rotor_speed_data(), e.num_envs(), e.model().num_rotors());
          },
          "(num_envs, num_rotors) copy of the rotor speeds each ended episode reached (valid "
          "where done).")
      .def(
          "target", [](const E& e, int env) { return copy_of(e.target(env)); }, py::arg("env"),
          "The hover or trajectory target of env `env` now (racing: the next gate's centre).");
}

}  // namespace

void bind_rl(py::module_& m) {
  bind_vec_env<double>(m, "VecEnv64");
  bind_vec_env<float>(m, "VecEnv32");
  py::list causes;
  for (std::string_view s : rl::kEndCauseNames) causes.append(std::string(s));
  m.attr("END_CAUSES") = causes;
  py::list terms;
  for (std::string_view s : rl::kRewardTermNames) terms.append(std::string(s));
  m.attr("REWARD_TERMS") = terms;
}

}  // namespace dronetwin::python
