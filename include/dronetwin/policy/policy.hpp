#pragma once
// A trained policy as a .dtpolicy file holds it (docs/policy-format.md): the network, the
// observation it expects (named pieces of the RL env, rl/observation.hpp), the action convention it
// produces and the provenance of its training. Read and written by config/policy_io.hpp.
//
//   PolicyFile p = read_policy("policies/hover_ctbr.dtpolicy");
//   require_env_match(p, env.observation_layout(), env.config().action,
//                     env.config().normalized_actions, env.action_size());
//   MlpEvaluator policy(std::make_shared<const Mlp>(std::move(p.mlp)));
//   policy.evaluate(observation, action);           // the action handed to env.step as is
//
// Trap: the network's output is the action in the env's convention (action_mode,
// normalized_actions); a program that flies the policy with another convention must refuse it
// (require_env_match), not rescale it.

#include <string>
#include <vector>

#include "dronetwin/policy/mlp.hpp"
#include "dronetwin/rl/env_config.hpp"
#include "dronetwin/rl/observation.hpp"

namespace dronetwin {

/// One piece of a policy's observation: its name (rl::kObservationPieceNames for dronetwin's
/// envs) and how many values it takes.
struct PolicyObservationPiece {
  std::string name;
  int size = 0;
  bool operator==(const PolicyObservationPiece&) const = default;
};

struct PolicyFile {
  Mlp mlp;
  /// The observation's pieces in order; their sizes sum to observation_size.
  std::vector<PolicyObservationPiece> observation;
  int observation_size = 0;  ///< = mlp.input_size()
  int action_size = 0;       ///< = mlp.output_size()
  /// The env's action mode (one of rl::kActionModeNames) and whether its actions are normalised
  /// to [-1, 1]: the network's output is the action handed to the env's step as is.
  std::string action_mode;
  bool normalized_actions = false;
  /// The provenance objects "env" and "training" as JSON text (compact, keys in file order,
  /// numbers as written); "{}" when empty. Not needed to evaluate the policy.
  std::string env_json = "{}";
  std::string training_json = "{}";
  /// Where it was read from (the file's path), for messages; "" for a policy built in memory.
  std::string source;
};

/// Throws InvalidArgument "<source or 'policy'>: <field>: expected ..., got ..." unless the file's
/// parts agree: validate(mlp); a non-empty observation list of named pieces with sizes >= 1 that
/// sum to observation_size; observation_size == mlp.input_size(); action_size ==
/// mlp.output_size(); action_mode one of rl::kActionModeNames. (The JSON of env_json and
/// training_json is checked by write_policy, which reads what it writes.)
void validate(const PolicyFile& policy);

/// Throws InvalidArgument "<source>: observation: ..." naming the first piece that differs when
/// the policy's observation is not `layout` (names and sizes in order), and "<source>:
/// action_mode / normalized_actions / action_size: the policy was trained with ..., the env
/// uses ..." when the action convention differs.
void require_env_match(const PolicyFile& policy, const std::vector<rl::PieceSlice>& layout,
                       rl::ActionMode action_mode, bool normalized_actions, int action_size);

}  // namespace dronetwin
