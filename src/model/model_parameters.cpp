// Names, units and VehicleSpec / VehicleParametersTpl access of the identifiable parameters
// (model_parameters.hpp).
#include "dronetwin/model/model_parameters.hpp"

#include <cmath>
#include <span>

#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

struct ParameterInfo {
  std::string_view name;
  std::string_view unit;
};

constexpr std::array<ParameterInfo, kNumModelParameters> kInfo{{
    {"mass", "kg"},
    {"inertia_xx", "kg m^2"},
    {"inertia_yy", "kg m^2"},
    {"inertia_zz", "kg m^2"},
    {"thrust_k1", "N s^2/rad^2"},
    {"thrust_k2", "N s/rad"},
    {"thrust_k3", "N"},
    {"yaw_moment_per_thrust", "m"},
    {"drag_moment", "m"},
    {"rotor_drag", "N s^2/(rad m)"},
    {"rolling_moment", "N s^2/rad"},
    {"body_drag_x", "N s/m"},
    {"body_drag_y", "N s/m"},
    {"body_drag_z", "N s/m"},
    {"ground_effect", "m^2"},
    {"tau_rise", "s"},
    {"tau_fall", "s"},
}};

using P = ModelParameter;

struct Group {
  std::string_view name;
  std::vector<ModelParameter> members;
};

const std::vector<Group>& groups() {
  static const std::vector<Group> g{
      {"thrust", {P::kThrustK1, P::kThrustK2, P::kThrustK3}},
      {"inertia", {P::kInertiaXX, P::kInertiaYY, P::kInertiaZZ}},
      {"body_drag", {P::kBodyDragX, P::kBodyDragY, P::kBodyDragZ}},
      {"motor", {P::kTauRise, P::kTauFall}},
  };
  return g;
}

std::string valid_names() {
  std::string s;
  for (const auto& i : kInfo) s += std::string(s.empty() ? "" : ", ") + std::string(i.name);
  for (const auto& g : groups()) s += ", " + std::string(g.name);
  return s;
}

// Pointer to the per-rotor field a parameter lives in (nullptr for the body-level ones); const
// or not as the rotor is.
template <class Rotor>
auto rotor_field(Rotor& r, ModelParameter p) -> decltype(&r.rotor_drag_coefficient) {
  switch (p) {
    case P::kThrustK1:
      return &r.thrust_coefficients[0];
    case P::kThrustK2:
      return &r.thrust_coefficients[1];
    case P::kThrustK3:
      return &r.thrust_coefficients[2];
    case P::kYawMomentPerThrust:
      return &r.yaw_moment_per_thrust_m;
    case P::kDragMoment:
      return &r.drag_moment_coefficient;
    case P::kRotorDrag:
      return &r.rotor_drag_coefficient;
    case P::kRollingMoment:
      return &r.rolling_moment_coefficient;
    case P::kGroundEffect:
      return &r.ground_effect_coefficient;
    case P::kTauRise:
      return &r.time_constant_rise_s;
    case P::kTauFall:
      return &r.time_constant_fall_s;
    default:
      return nullptr;
  }
}

template <class Spec>
auto body_field(Spec& s, ModelParameter p) -> decltype(&s.mass_kg) {
  switch (p) {
    case P::kMass:
      return &s.mass_kg;
    case P::kInertiaXX:
      return &s.inertia_kgm2(0, 0);
    case P::kInertiaYY:
      return &s.inertia_kgm2(1, 1);
    case P::kInertiaZZ:
      return &s.inertia_kgm2(2, 2);
    case P::kBodyDragX:
      return &s.body_drag_Ns_per_m(0, 0);
    case P::kBodyDragY:
      return &s.body_drag_Ns_per_m(1, 1);
    case P::kBodyDragZ:
      return &s.body_drag_Ns_per_m(2, 2);
    default:
      return nullptr;
  }
}

}  // namespace

std::string_view parameter_name(ModelParameter p) {
  return kInfo[static_cast<std::size_t>(p)].name;
}
std::string_view parameter_unit(ModelParameter p) {
  return kInfo[static_cast<std::size_t>(p)].unit;
}

std::vector<ModelParameter> parse_parameter_list(std::string_view list) {
  std::array<bool, kNumModelParameters> chosen{};
  std::size_t start = 0;
  bool any = false;
  while (start <= list.size()) {
    std::size_t end = list.find(',', start);
    if (end == std::string_view::npos) end = list.size();
    std::string_view item = list.substr(start, end - start);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    require(!item.empty(), "parameter list '", list, "': empty entry at character ", start,
            " (valid: ", valid_names(), ")");
    bool known = false;
    for (int i = 0; i < kNumModelParameters; ++i) {
      if (kInfo[static_cast<std::size_t>(i)].name == item)
        chosen[static_cast<std::size_t>(i)] = known = true;
    }
    for (const auto& g : groups()) {
      if (g.name != item) continue;
      known = true;
      for (ModelParameter m : g.members) chosen[static_cast<std::size_t>(m)] = true;
    }
    require(known, "parameter list '", list, "': unknown parameter '", item,
            "' (valid: ", valid_names(), ")");
    any = true;
    start = end + 1;
  }
  require(any, "parameter list is empty (valid: ", valid_names(), ")");
  std::vector<ModelParameter> out;
  for (int i = 0; i < kNumModelParameters; ++i) {
    if (chosen[static_cast<std::size_t>(i)]) out.push_back(static_cast<ModelParameter>(i));
  }
  return out;
}

namespace {
// The rotors of a spec (all of them) or of parameters (the first num_rotors).
std::span<const RotorParams> rotors_of(const VehicleSpec& s) { return s.rotors; }
std::span<RotorParams> rotors_of(VehicleSpec& s) { return s.rotors; }
std::span<const RotorParams> rotors_of(const VehicleParametersTpl<double>& s) {
  return {s.rotors.data(), static_cast<std::size_t>(s.num_rotors)};
}
std::span<RotorParams> rotors_of(VehicleParametersTpl<double>& s) {
  return {s.rotors.data(), static_cast<std::size_t>(s.num_rotors)};
}

template <class Spec>
double value_in(const Spec& spec, ModelParameter p, std::string_view source) {
  if (const double* v = body_field(spec, p)) return *v;
  const auto rotors = rotors_of(spec);
  require(!rotors.empty(), source, ": model has no rotors");
  double sum = 0.0;
  for (const RotorParams& r : rotors) sum += *rotor_field(r, p);
  return sum / static_cast<double>(rotors.size());
}

template <class Spec>
void set_value_in(Spec& spec, ModelParameter p, double value, std::string_view source) {
  require(std::isfinite(value), "set_parameter_value: ", parameter_name(p), " = ", value,
          " is not finite");
  if (double* v = body_field(spec, p)) {
    *v = value;
    return;
  }
  const double mean = value_in(spec, p, source);
  for (RotorParams& r : rotors_of(spec)) {
    double* f = rotor_field(r, p);
    *f = mean != 0.0 ? *f * (value / mean) : value;
  }
}
}  // namespace

double parameter_value(const VehicleSpec& spec, ModelParameter p) {
  return value_in(spec, p, spec.source);
}

void set_parameter_value(VehicleSpec& spec, ModelParameter p, double value) {
  set_value_in(spec, p, value, spec.source);
}

double parameter_value(const VehicleParametersTpl<double>& parameters, ModelParameter p) {
  return value_in(parameters, p, "vehicle parameters");
}

void set_parameter_value(VehicleParametersTpl<double>& parameters, ModelParameter p, double value) {
  set_value_in(parameters, p, value, "vehicle parameters");
}

}  // namespace dronetwin
