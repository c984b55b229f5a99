#pragma once
// Reading and writing vehicle model files (YAML). The format is documented in
// docs/model-format.md. Parsing is strict: an unknown key, a missing required key, a wrong
// vector length or a non-number is an InvalidArgument naming the file, the field and the value.
//
//   VehicleModel m = load_vehicle_model("models/qdrone2.yaml");

#include <string>

#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// Parses a model file into a spec (syntax and key checks only; physical checks happen in
/// VehicleModel's constructor). `path` is used for reading and in error messages.
VehicleSpec load_vehicle_spec(const std::string& path);

/// Same, from YAML text; `source_name` stands for the file in error messages.
VehicleSpec parse_vehicle_spec(const std::string& yaml_text, const std::string& source_name);

/// load_vehicle_spec + validation and derived quantities.
VehicleModel load_vehicle_model(const std::string& path);

/// Writes a spec as a model file that load_vehicle_spec reads back to the same numbers
/// (full precision, one explicit entry per rotor). Atomically (logging/atomic_file.hpp): a
/// failure leaves an existing file as it was, and the message says why (errno).
void save_vehicle_spec(const VehicleSpec& spec, const std::string& path);

/// The YAML text save_vehicle_spec would write.
std::string vehicle_spec_to_yaml(const VehicleSpec& spec);

}  // namespace dronetwin
