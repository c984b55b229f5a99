#pragma once
// Reading racing-track files (config/tracks/*.yaml; format in docs/track-format.md). Strict: an
// unknown key, a missing key, a wrong vector length, a non-number, a size <= 0, a gate or the
// start outside the arena, two consecutive gates at one place or a repeated gate name is an
// InvalidArgument naming the file and the field ("circuit.yaml: gates[3].width_m: ...").
//
//   Track t = load_track("config/tracks/circuit.yaml");

#include <string>

#include "dronetwin/world/track.hpp"

namespace dronetwin {

Track load_track(const std::string& path);
/// Same from YAML text; `source_name` stands for the file in messages.
Track parse_track(const std::string& yaml_text, const std::string& source_name);

}  // namespace dronetwin
