#pragma once
// Reading RL environment files (config/rl/*.yaml; format in docs/rl.md): the vehicle model, the
// task, action mode, observation, reward, randomisation and physics of a VecEnv. Strict like
// every loader: unknown keys, wrong types and bad values are InvalidArgument naming the file and
// the field. Files named inside (model, track, SE(3) controller) are relative to the file.
//
//   EnvFile f = load_env_config("config/rl/racing.yaml", "{episode_time_s: 10}");
//   rl::VecEnv<float> env(f.model, f.config, 1024, 2);

#include <memory>
#include <string>

#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/rl/env_config.hpp"

namespace dronetwin {

struct EnvFile {
  std::string source;
  std::string description;
  std::shared_ptr<const VehicleModel> model;
  rl::EnvConfig config;
};

/// The env of file `path`, with `overrides` (YAML or JSON text of a map, may be empty) merged
/// over the file first: a map merges key by key, anything else replaces the file's value. Errors
/// name `path` (and say "(with overrides)" when the overrides were involved).
EnvFile load_env_config(const std::string& path, const std::string& overrides = "");

/// Same from text; `source_name` stands for the file (and locates the files it names).
EnvFile parse_env_config(const std::string& yaml_text, const std::string& source_name,
                         const std::string& overrides = "");

}  // namespace dronetwin
