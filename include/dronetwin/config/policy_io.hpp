#pragma once
// Reading and writing trained-policy files (.dtpolicy, format version 1;
// docs/policy-format.md): a 16-byte preamble (magic, version, header length), a JSON header
// (parsed strictly through yaml-cpp: unknown and missing keys, wrong types and YAML that is not
// JSON are refused) and the float32 tensors. Every malformed file is an InvalidArgument naming
// the file, the field or tensor and what was expected against what was found:
//
//   "hover.dtpolicy: header: network.layers[0]: expected observation_size (6), got 7 (line 9)"
//   "hover.dtpolicy: truncated: expected 17924 bytes of tensors after the header, got 17000"
//   "hover.dtpolicy: tensor layers.1.weight: element [3, 5] is nan (expected finite numbers)"
//
//   PolicyFile p = read_policy("policies/hover_ctbr.dtpolicy");
//   MlpEvaluator policy(std::make_shared<const Mlp>(p.mlp));
//   write_policy(p, "out/copy.dtpolicy");              // atomic; bit-exact when read back
//
// Hostile files: sizes are checked against the file's length before anything is allocated for
// the tensors (widths at most Mlp::kMaxWidth, the header at most 1 MiB), so memory stays within
// a small multiple of the file's size.
//
// Trap: the tensors are float32. write_policy rounds the network's doubles to float32; a network
// read from a file (whose numbers came from float32) writes back bit for bit.

#include <cstdint>
#include <string>
#include <string_view>

#include "dronetwin/policy/policy.hpp"

namespace dronetwin {

inline constexpr std::string_view kPolicyMagic = "DTPOLICY";
inline constexpr std::string_view kPolicyFormat = "dronetwin.policy";
inline constexpr std::uint32_t kPolicyFormatVersion = 1;
inline constexpr std::uint32_t kMaxPolicyHeaderBytes = 1u << 20;  // 1 MiB

/// Reads a .dtpolicy file; PolicyFile::source is `path`.
PolicyFile read_policy(const std::string& path);

/// Same from the file's bytes; `source_name` stands for the file in messages and is the
/// PolicyFile's source.
PolicyFile parse_policy(std::string_view bytes, const std::string& source_name);

/// The bytes of the .dtpolicy file of `policy` (the header written with "%.17g" numbers, the
/// tensors rounded to float32). InvalidArgument when validate(policy) fails or env_json /
/// training_json is not a JSON object; the bytes are read back with parse_policy before they are
/// returned, so whatever this returns reads.
std::string policy_file_bytes(const PolicyFile& policy);

/// Writes policy_file_bytes(policy) to `path` atomically (logging/atomic_file.hpp): an existing
/// file is replaced in one rename, never left half-written. InvalidArgument naming `path` on
/// failure.
void write_policy(const PolicyFile& policy, const std::string& path);

}  // namespace dronetwin
