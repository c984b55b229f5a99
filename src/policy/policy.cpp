// A trained policy's file contents (policy.hpp): consistency and the match with an env.
#include "dronetwin/policy/policy.hpp"

#include <algorithm>
#include <string>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {
std::string name_of(const PolicyFile& p) { return p.source.empty() ? "policy" : p.source; }

std::string piece_text(const std::string& name, int size) {
  std::string out = name;
  out += " (";
  out += std::to_string(size);
  out += ')';
  return out;
}
}  // namespace

void validate(const PolicyFile& p) {
  const std::string src = name_of(p);
  try {
    validate(p.mlp);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(src + ": " + e.what());
  }
  require(!p.observation.empty(), src, ": observation: expected at least one piece, got none");
  long long sum = 0;
  for (std::size_t i = 0; i < p.observation.size(); ++i) {
    const PolicyObservationPiece& piece = p.observation[i];
    require(!piece.name.empty(), src, ": observation[", i, "].name: expected a non-empty name");
    require(piece.size >= 1 && piece.size <= Mlp::kMaxWidth, src, ": observation[", i,
            "].size: expected an integer in [1, ", Mlp::kMaxWidth, "], got ", piece.size);
    sum += piece.size;
  }
  require(sum == p.observation_size, src, ": observation: the piece sizes sum to ", sum,
          ", observation_size is ", p.observation_size);
  require(p.observation_size == p.mlp.input_size(), src, ": observation_size: expected ",
          p.mlp.input_size(), " (the network's input size), got ", p.observation_size);
  require(p.action_size == p.mlp.output_size(), src, ": action_size: expected ",
          p.mlp.output_size(), " (the network's output size), got ", p.action_size);
  const auto& modes = rl::kActionModeNames;
  require(std::find(modes.begin(), modes.end(), p.action_mode) != modes.end(), src,
          ": action_mode: expected one of relative_position, global_position, rotor_speeds, "
          "ctbr, generalized_force, got \"",
          p.action_mode, "\"");
}

void require_env_match(const PolicyFile& p, const std::vector<rl::PieceSlice>& layout,
                       rl::ActionMode action_mode, bool normalized_actions, int action_size) {
  const std::string src = name_of(p);
  // The action convention first: a different one also changes previous_action's size.
  const std::string_view mode = rl::kActionModeNames[static_cast<int>(action_mode)];
  require(p.action_mode == mode, src, ": action_mode: the policy was trained with \"",
          p.action_mode, "\", the env uses \"", mode, "\"");
  require(p.normalized_actions == normalized_actions, src,
          ": normalized_actions: the policy was trained with ",
          p.normalized_actions ? "true" : "false", ", the env uses ",
          normalized_actions ? "true" : "false");
  require(p.action_size == action_size, src, ": action_size: the policy gives ", p.action_size,
          " values, the env takes ", action_size);
  const std::size_t n = std::max(layout.size(), p.observation.size());
  for (std::size_t i = 0; i < n; ++i) {
    const std::string ours = i < p.observation.size()
                                 ? piece_text(p.observation[i].name, p.observation[i].size)
                                 : std::string("nothing");
    const std::string theirs =
        i < layout.size()
            ? piece_text(std::string(rl::kObservationPieceNames[static_cast<int>(layout[i].piece)]),
                         layout[i].size)
            : std::string("nothing");
    require(ours == theirs, src, ": observation[", i, "]: the policy was trained on ", ours,
            ", the env observes ", theirs);
  }
}

}  // namespace dronetwin
