// Bindings of trained policies (policy/mlp.hpp, policy/policy.hpp, config/policy_io.hpp):
// Policy(path) reads a .dtpolicy file and evaluates its network in C++ (double), without torch.
// The Python front end is python/dronetwin/policy.py.

#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <string>

#include "bindings.hpp"
#include "dronetwin/config/policy_io.hpp"
#include "dronetwin/policy/mlp.hpp"
#include "dronetwin/policy/policy.hpp"
#include "dronetwin/rl/env_config.hpp"

namespace dronetwin::python {

namespace {

/// A policy file and an evaluator of its network. The evaluator's workspace is shared by the
/// calls, so they take turns (the mutex), with the GIL released while they compute.
class PyPolicy {
 public:
  explicit PyPolicy(const std::string& path)
      : file_(read_policy(path)), evaluator_(std::make_shared<const Mlp>(std::move(file_.mlp))) {}

  const PolicyFile& file() const { return file_; }
  const Mlp& mlp() const { return evaluator_.mlp(); }

  py::array_t<double> evaluate(py::handle observations) {
    const auto n_in = static_cast<py::ssize_t>(evaluator_.input_size());
    const auto n_out = static_cast<py::ssize_t>(evaluator_.output_size());
    py::array a = py::array::ensure(observations);
    const auto expected = [&] {
      return "evaluate: observations: expected a float64 or float32 array of shape (n, " +
             std::to_string(n_in) + ") or (" + std::to_string(n_in) + ",), got " +
             describe_object(observations);
    };
    if (!a) throw py::type_error(expected());
    const bool is_f64 = a.dtype().is(py::dtype::of<double>());
    const bool is_f32 = a.dtype().is(py::dtype::of<float>());
    if (!is_f64 && !is_f32) throw py::type_error(expected());
    const bool one = a.ndim() == 1;
    if (!(one && a.shape(0) == n_in) && !(a.ndim() == 2 && a.shape(1) == n_in))
      throw py::value_error(expected());
    const py::ssize_t rows = one ? 1 : a.shape(0);
    py::array_t<double> out = one ? py::array_t<double>(n_out) : py::array_t<double>({rows, n_out});
    double* actions = out.mutable_data();
    if (is_f64) {
      const auto c =
          py::array_t<double, py::array::c_style>::ensure(a);  // same dtype: no conversion
      const double* obs = c.data();
      py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock(mutex_);
      evaluator_.evaluate_rows(obs, rows, actions);
    } else {
      const auto c = py::array_t<float, py::array::c_style>::ensure(a);
      const float* obs = c.data();
      py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock(mutex_);
      evaluator_.evaluate_rows(obs, rows, actions);
    }
    return out;
  }

 private:
  PolicyFile file_;  // its mlp moved into the evaluator
  MlpEvaluator evaluator_;
  std::mutex mutex_;
};

}  // namespace

void bind_policy(py::module_& m) {
  py::class_<PyPolicy>(m, "Policy",
                       "A trained policy read from a .dtpolicy file (docs/policy-format.md), "
                       "evaluated in C++ in float64; use dronetwin.policy.load rather than this "
                       "class")
      .def(py::init<const std::string&>(), py::arg("path"),
           "Reads the .dtpolicy file at `path`; ValueError naming the file, the field or tensor "
           "and what was expected for a malformed one.")
      .def("evaluate", &PyPolicy::evaluate, py::arg("observations"),
           "The actions for float64 or float32 observations of shape (n, observation_size) or "
           "(observation_size,): a float64 array of shape (n, action_size) or (action_size,). "
           "ValueError for a non-finite observation (naming its row and column).")
      .def("__call__", &PyPolicy::evaluate, py::arg("observations"), "Same as evaluate().")
      .def(
          "require_env_match",
          [](const PyPolicy& p, py::handle env) {
            // The engine behind dronetwin.rl.VectorEnv (VecEnv64/VecEnv32): its layout and
            // action convention, checked by the C++ rule (policy/policy.hpp).
            std::vector<rl::PieceSlice> layout;
            for (const py::handle item : env.attr("observation_layout")) {
              const auto t = item.cast<py::tuple>();
              layout.push_back({rl::observation_piece_from_name(t[0].cast<std::string>()),
                                t[1].cast<int>(), t[2].cast<int>()});
            }
            require_env_match(
                p.file(), layout,
                rl::action_mode_from_name(env.attr("action_mode").cast<std::string>()),
                env.attr("normalized_actions").cast<bool>(), env.attr("action_size").cast<int>());
          },
          py::arg("env"),
          "ValueError naming what differs when the policy was trained with another observation "
          "layout (piece by piece) or action convention than the env engine `env` "
          "(VectorEnv._env) uses.")
      .def_property_readonly(
          "observation",
          [](const PyPolicy& p) {
            py::list out;
            for (const PolicyObservationPiece& piece : p.file().observation)
              out.append(py::make_tuple(piece.name, piece.size));
            return out;
          },
          "The observation's pieces in order, as (name, size) tuples.")
      .def_property_readonly(
          "observation_size", [](const PyPolicy& p) { return p.file().observation_size; },
          "Values per observation (the network's input size).")
      .def_property_readonly(
          "action_size", [](const PyPolicy& p) { return p.file().action_size; },
          "Values per action (the network's output size).")
      .def_property_readonly(
          "action_mode", [](const PyPolicy& p) { return p.file().action_mode; },
          "The env's action mode the policy was trained with (\"ctbr\", ...).")
      .def_property_readonly(
          "normalized_actions", [](const PyPolicy& p) { return p.file().normalized_actions; },
          "Whether the actions are normalised to [-1, 1] (the env's normalized_actions).")
      .def_property_readonly(
          "layers", [](const PyPolicy& p) { return p.mlp().layer_widths(); },
          "The network's widths, observation_size first and action_size last.")
      .def_property_readonly(
          "activation",
          [](const PyPolicy& p) {
            return std::string(kActivationNames[static_cast<int>(p.mlp().activation)]);
          },
          "The hidden layers' activation: \"leaky_relu\", \"relu\" or \"tanh\".")
      .def_property_readonly(
          "output",
          [](const PyPolicy& p) {
            return std::string(kOutputSquashNames[static_cast<int>(p.mlp().output)]);
          },
          "What the last layer goes through before action_scale: \"tanh\" or \"identity\".")
      .def_property_readonly(
          "env_json", [](const PyPolicy& p) { return p.file().env_json; },
          "The file's provenance object \"env\" as JSON text (json.loads it).")
      .def_property_readonly(
          "training_json", [](const PyPolicy& p) { return p.file().training_json; },
          "The file's provenance object \"training\" as JSON text (json.loads it).")
      .def_property_readonly(
          "source", [](const PyPolicy& p) { return p.file().source; },
          "The path the policy was read from.")
      .def("__repr__", [](const PyPolicy& p) {
        std::string layers;
        for (const int w : p.mlp().layer_widths()) {
          if (!layers.empty()) layers += ", ";
          layers += std::to_string(w);
        }
        std::string out = "Policy('";
        out += p.file().source;
        out += "', layers=[";
        out += layers;
        out += "], action_mode='";
        out += p.file().action_mode;
        out += "')";
        return out;
      });
}

}  // namespace dronetwin::python
