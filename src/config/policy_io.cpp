// Reading and writing trained-policy files (policy_io.hpp; docs/policy-format.md). The JSON
// header goes through yaml-cpp like the log sidecars (log_metadata_reader.cpp), with two more
// checks that keep YAML out of a JSON header: its structure (one object, JSON's punctuation,
// no trailing commas, bounded nesting) before yaml-cpp sees it, and its values (quoted keys,
// numbers, true, false, null) after.
#include "dronetwin/config/policy_io.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/atomic_file.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {

namespace {

using io_detail::Map;
using io_detail::Reader;
using Names = std::vector<std::string_view>;

const Names kTopKeys = {
    "format",      "format_version",     "observation", "observation_size", "action_size",
    "action_mode", "normalized_actions", "network",     "tensors",          "env",
    "training"};
const Names kNetworkKeys = {"layers", "activation",   "negative_slope",
                            "output", "action_scale", "observation_clip"};
const Names kPieceKeys = {"name", "size"};
const Names kTensorKeys = {"name", "shape"};
// In the order of Mlp::Activation and Mlp::OutputSquash.
const Names kActivations = {kActivationNames[0], kActivationNames[1], kActivationNames[2]};
const Names kOutputs = {kOutputSquashNames[0], kOutputSquashNames[1]};
const Names kActionModes(rl::kActionModeNames.begin(), rl::kActionModeNames.end());

constexpr std::size_t kPreambleBytes = 16;
constexpr std::size_t kMaxJsonDepth = 64;

static_assert(std::endian::native == std::endian::little ||
              std::endian::native == std::endian::big);

std::uint32_t u32_le(std::string_view bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t k = 0; k < 4; ++k)
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + k])) << (8 * k);
  return v;
}

void append_u32_le(std::string& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFFu));
}

/// Bytes for a message: printable ASCII as is, anything else as \xNN, in double quotes.
std::string printable(std::string_view bytes) {
  std::string out(1, '"');
  for (const char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7F && c != '"' && c != '\\') {
      out.push_back(c);
    } else {
      char code[8];
      std::snprintf(code, sizeof code, "\\x%02X", static_cast<unsigned>(u));
      out += code;
    }
  }
  out.push_back('"');
  return out;
}

/// A character of the header for a message: 'x' for printable ASCII, byte 0xNN otherwise.
std::string character(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (u >= 0x20 && u < 0x7F) return std::string("'") + c + "'";
  char code[16];
  std::snprintf(code, sizeof code, "byte 0x%02X", static_cast<unsigned>(u));
  return code;
}

// ---- JSON, strictly -------------------------------------------------------------------------

/// The structure of a JSON object text, checked before yaml-cpp (which reads YAML, a superset)
/// parses it: the text is one object and nothing follows it; outside strings there are only
/// whitespace, JSON's punctuation and the characters of numbers and of true, false and null (no
/// comments, anchors, tags or other YAML); no comma before a closing bracket; at most
/// kMaxJsonDepth levels of nesting (which also bounds the recursion of what reads it after).
void require_json_object_text(const std::string& text, const std::string& source) {
  std::size_t line = 1, line_start = 0;
  const auto fail_at = [&](std::size_t i, const std::string& what) {
    std::size_t column = 1;  // characters, not bytes
    for (std::size_t k = line_start; k < i && k < text.size(); ++k)
      column += (static_cast<unsigned char>(text[k]) & 0xC0) != 0x80;
    std::string message = source;
    message += ": line ";
    message += std::to_string(line);
    message += ", column ";
    message += std::to_string(column);
    message += ": ";
    message += what;
    throw InvalidArgument(message);
  };
  std::string open;  // the unclosed '{' and '['
  bool in_string = false, started = false, done = false;
  char previous = 0;  // the last character outside strings that is not whitespace
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = i + 1;
    }
    if (in_string) {
      if (c == '\\') {
        ++i;  // the escaped character (load_json checks the escapes)
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') continue;
    if (done) fail_at(i, "unexpected " + character(c) + " after the end of the JSON object");
    if (!started && c != '{')
      fail_at(i, "expected a JSON object (starting with '{'), got " + character(c));
    switch (c) {
      case '"':
        in_string = true;
        break;
      case '{':
      case '[':
        if (open.size() == kMaxJsonDepth) {
          fail_at(i, "objects and arrays nested deeper than " + std::to_string(kMaxJsonDepth) +
                         " levels");
        }
        open.push_back(c);
        started = true;
        break;
      case '}':
      case ']':
        if (previous == ',') {
          fail_at(i, "a comma before " + character(c) + " (JSON has no trailing commas)");
        }
        if (open.empty() || open.back() != (c == '}' ? '{' : '[')) {
          fail_at(i, "unexpected " + character(c) + " (it closes no " +
                         (c == '}' ? "object" : "array") + ")");
        }
        open.pop_back();
        done = open.empty();
        break;
      case ',':
      case ':':
        break;
      default: {
        const bool literal = (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') ||
                             (c >= 'A' && c <= 'Z') || c == '-' || c == '+' || c == '.' ||
                             c == '_';  // not JSON either, but named better by the values check
        if (c == '\'') fail_at(i, "a single quote (JSON strings are in double quotes)");
        if (!literal) fail_at(i, "unexpected " + character(c) + " (not JSON)");
      }
    }
    previous = c;
  }
  if (in_string) fail_at(text.size(), "the text ends inside a string");
  if (!started) fail_at(text.size(), "expected a JSON object, got no value");
  if (!done) {
    fail_at(text.size(), "the text ends inside " + std::to_string(open.size()) +
                             " unclosed object(s) or array(s)");
  }
}

/// -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][-+]?[0-9]+)?, JSON's number grammar.
bool is_json_number(std::string_view s) {
  std::size_t i = 0;
  const auto digits = [&] {
    const std::size_t start = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    return i > start;
  };
  if (i < s.size() && s[i] == '-') ++i;
  if (i < s.size() && s[i] == '0') {
    ++i;
  } else if (!digits()) {
    return false;
  }
  if (i < s.size() && s[i] == '.') {
    ++i;
    if (!digits()) return false;
  }
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '-' || s[i] == '+')) ++i;
    if (!digits()) return false;
  }
  return i == s.size();
}

/// A double-quoted scalar (yaml-cpp tags those "!", plain ones "?").
bool is_quoted(const YAML::Node& node) { return node.IsScalar() && node.Tag() == "!"; }

/// Every value of a parsed JSON text as JSON has it: keys are strings in double quotes, each
/// once per object; a value without quotes is a number, true, false or null; strings are UTF-8
/// once their escapes are decoded. `text` is what was parsed (to tell null from a missing value).
void require_json_values(const Reader& rd, const YAML::Node& node, const std::string& path,
                         const std::string& text) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      std::set<std::string, std::less<>> keys;
      for (const auto& kv : node) {
        if (!is_quoted(kv.first)) {
          rd.fail(
              kv.first, path,
              "expected keys to be strings in double quotes, got " + io_detail::describe(kv.first));
        }
        const std::string& key = kv.first.Scalar();
        if (!io_detail::is_utf8(key)) rd.fail(kv.first, path, io_detail::kNotUtf8AfterEscapes);
        if (!keys.insert(key).second) rd.fail(kv.first, path, "duplicate key '" + key + "'");
        require_json_values(rd, kv.second, io_detail::child_path(path, key), text);
      }
      break;
    }
    case YAML::NodeType::Sequence:
      for (std::size_t i = 0; i < node.size(); ++i)
        require_json_values(rd, node[i], io_detail::item_path(path, i), text);
      break;
    case YAML::NodeType::Scalar:
      if (is_quoted(node)) {
        if (!io_detail::is_utf8(node.Scalar()))
          rd.fail(node, path, io_detail::kNotUtf8AfterEscapes);
      } else if (node.Tag() != "?" || !(node.Scalar() == "true" || node.Scalar() == "false" ||
                                        is_json_number(node.Scalar()))) {
        rd.fail(node, path,
                "expected a JSON value (a string in double quotes, a number, true, false or "
                "null), got " +
                    io_detail::describe(node));
      }
      break;
    case YAML::NodeType::Null: {
      // yaml-cpp reads null, Null, NULL and a missing value alike; JSON has only the first.
      const auto at = static_cast<std::size_t>(std::max(node.Mark().pos, 0));
      if (node.Mark().pos < 0 || text.compare(at, 4, "null") != 0)
        rd.fail(path, "expected a JSON value (null is spelled null), got nothing");
      break;
    }
    case YAML::NodeType::Undefined:
      break;
  }
}

/// `node` (checked by require_json_values) as compact JSON: ", " and ": " separators, keys in
/// file order, numbers as written.
void append_json(const YAML::Node& node, std::string& out) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      out.push_back('{');
      bool first = true;
      for (const auto& kv : node) {
        if (!first) out += ", ";
        first = false;
        out += json::json_string(kv.first.Scalar());
        out += ": ";
        append_json(kv.second, out);
      }
      out.push_back('}');
      break;
    }
    case YAML::NodeType::Sequence:
      out.push_back('[');
      for (std::size_t i = 0; i < node.size(); ++i) {
        if (i) out += ", ";
        append_json(node[i], out);
      }
      out.push_back(']');
      break;
    case YAML::NodeType::Scalar:
      out += is_quoted(node) ? json::json_string(node.Scalar()) : node.Scalar();
      break;
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      out += "null";
      break;
  }
}

/// A JSON object text, strictly (the checks above and io_detail::load_json's).
YAML::Node load_json_object(const std::string& text, const std::string& source) {
  io_detail::require_utf8(text, source, "JSON");
  require_json_object_text(text, source);
  const YAML::Node root = io_detail::load_json(text, source);
  const Reader rd(source);
  if (!root.IsMap()) rd.fail(root, "", "expected a JSON object, got " + io_detail::describe(root));
  require_json_values(rd, root, "", text);
  return root;
}

// ---- the header -----------------------------------------------------------------------------

/// A JSON string (quoted: a bare word is not one), non-empty.
std::string text(const Reader& rd, const YAML::Node& node, const std::string& path) {
  if (!is_quoted(node) || node.Scalar().empty())
    rd.fail(node, path, "expected a non-empty string, got " + io_detail::describe(node));
  return node.Scalar();
}

/// An integer in [lo, hi].
std::int64_t bounded(const Reader& rd, const YAML::Node& node, const std::string& path,
                     std::int64_t lo, std::int64_t hi) {
  std::string what = "an integer in [";
  what += std::to_string(lo);
  what += ", ";
  what += std::to_string(hi);
  what += ']';
  const auto v = rd.integer<std::int64_t>(node, path, what);
  if (v < lo || v > hi) rd.fail(node, path, "expected " + what + ", got " + std::to_string(v));
  return v;
}

std::string shape_text(const std::vector<std::int64_t>& shape) {
  std::string out(1, '[');
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i) out += ", ";
    out += std::to_string(shape[i]);
  }
  out.push_back(']');
  return out;
}

/// One tensor the header announces, in file order.
struct TensorSpec {
  std::string name;
  std::vector<std::int64_t> shape;  // [n] or [out, in]
  std::string meaning;              // where the shape comes from, for messages
  std::uint64_t count() const {
    std::uint64_t n = 1;
    for (const std::int64_t d : shape) n *= static_cast<std::uint64_t>(d);
    return n;
  }
};

/// The header read and checked, and where the tensors are.
struct Header {
  PolicyFile file;
  std::vector<TensorSpec> tensors;
  std::uint64_t tensor_offset = 0;  // 16 + header length
  std::uint64_t tensor_bytes = 0;   // what the header announces; the file holds exactly this
};

/// Reads the preamble and the header from `prefix` (the file's first bytes: at least
/// min(file_size, 16 + kMaxPolicyHeaderBytes) of them) and checks the sizes against
/// `file_size`, before anything is allocated for the tensors.
Header read_header(std::string_view prefix, std::uint64_t file_size, const std::string& src) {
  // Preamble.
  if (file_size < kPolicyMagic.size() || prefix.substr(0, kPolicyMagic.size()) != kPolicyMagic) {
    const std::string_view start = prefix.substr(0, std::min<std::size_t>(prefix.size(), 8));
    throw InvalidArgument(detail::concat(
        src, ": not a dronetwin policy file: expected the magic \"DTPOLICY\" in bytes 0-7, got ",
        file_size < kPolicyMagic.size() ? detail::concat("a file of ", file_size, " bytes")
                                        : printable(start)));
  }
  require(file_size >= kPreambleBytes, src, ": truncated: expected at least ", kPreambleBytes,
          " bytes (magic, format version, header length), got ", file_size);
  const std::uint32_t version = u32_le(prefix, 8);
  require(version == kPolicyFormatVersion, src, ": format version: this dronetwin reads version ",
          kPolicyFormatVersion, ", got ", version);
  const std::uint32_t header_length = u32_le(prefix, 12);
  require(header_length <= kMaxPolicyHeaderBytes, src, ": header length: expected at most ",
          kMaxPolicyHeaderBytes, " bytes (1 MiB), got ", header_length);
  require(kPreambleBytes + header_length <= file_size, src, ": truncated: the header length is ",
          header_length, " bytes, but only ", file_size - kPreambleBytes,
          " bytes follow the 16-byte preamble");

  Header h;
  PolicyFile& p = h.file;
  p.source = src;
  h.tensor_offset = kPreambleBytes + header_length;
  const std::string hsrc = src + ": header";
  const std::string header_text(prefix.substr(kPreambleBytes, header_length));
  const YAML::Node root = load_json_object(header_text, hsrc);
  const Reader rd(hsrc);

  // The format first: another file's header has other fields, and saying so beats listing them
  // as unknown keys.
  const YAML::Node format = root["format"];
  if (!format) rd.fail(root, "", "missing required key 'format'");
  const std::string format_name = text(rd, format, "format");
  if (format_name != kPolicyFormat) {
    rd.fail(format, "format",
            "expected \"" + std::string(kPolicyFormat) + "\", got \"" + format_name + "\"");
  }
  const Map top =
      rd.map(root, "", kTopKeys, "a JSON object with the fields " + io_detail::name_list(kTopKeys));
  for (const std::string_view key : kTopKeys) top.required(key);  // every field is required
  const auto field = [&](std::string_view key) { return top.get(key); };
  const auto path = [&](std::string_view key) { return top.path(key); };

  const std::int64_t format_version =
      rd.integer<std::int64_t>(field("format_version"), path("format_version"), "an integer");
  if (format_version != version) {
    rd.fail(field("format_version"), path("format_version"),
            "expected " + std::to_string(version) + " (the version in the preamble), got " +
                std::to_string(format_version));
  }

  p.observation_size = static_cast<int>(
      bounded(rd, field("observation_size"), path("observation_size"), 1, Mlp::kMaxWidth));
  p.action_size =
      static_cast<int>(bounded(rd, field("action_size"), path("action_size"), 1, Mlp::kMaxWidth));

  {
    const YAML::Node obs = field("observation");
    const std::string opath = path("observation");
    if (!obs.IsSequence() || obs.size() == 0) {
      rd.fail(obs, opath,
              "expected a non-empty array of {\"name\", \"size\"} objects, got " +
                  io_detail::describe(obs));
    }
    std::int64_t sum = 0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
      const std::string ip = io_detail::item_path(opath, i);
      const Map piece = rd.map(obs[i], ip, kPieceKeys, "an object with the fields name, size");
      PolicyObservationPiece entry;
      entry.name = text(rd, piece.required("name"), piece.path("name"));
      entry.size = static_cast<int>(
          bounded(rd, piece.required("size"), piece.path("size"), 1, Mlp::kMaxWidth));
      sum += entry.size;
      p.observation.push_back(std::move(entry));
    }
    if (sum != p.observation_size) {
      rd.fail(obs, opath,
              "the piece sizes sum to " + std::to_string(sum) + ", observation_size is " +
                  std::to_string(p.observation_size));
    }
  }

  const std::size_t mode =
      rd.choice(field("action_mode"), path("action_mode"), kActionModes, "action mode");
  p.action_mode = std::string(kActionModes[mode]);
  p.normalized_actions = rd.boolean(field("normalized_actions"), path("normalized_actions"));

  Mlp& m = p.mlp;
  std::vector<std::int64_t> widths;
  {
    const std::string npath = path("network");
    const Map net = rd.map(field("network"), npath, kNetworkKeys,
                           "an object with the fields " + io_detail::name_list(kNetworkKeys));
    for (const std::string_view key : kNetworkKeys) net.required(key);
    const YAML::Node layers = net.get("layers");
    const std::string lpath = net.path("layers");
    if (!layers.IsSequence() || layers.size() < 2) {
      rd.fail(layers, lpath,
              "expected an array of at least 2 widths (observation_size first, action_size "
              "last), got " +
                  io_detail::describe(layers));
    }
    for (std::size_t i = 0; i < layers.size(); ++i)
      widths.push_back(bounded(rd, layers[i], io_detail::item_path(lpath, i), 1, Mlp::kMaxWidth));
    if (widths.front() != p.observation_size) {
      rd.fail(layers[0], io_detail::item_path(lpath, 0),
              "expected observation_size (" + std::to_string(p.observation_size) + "), got " +
                  std::to_string(widths.front()));
    }
    if (widths.back() != p.action_size) {
      rd.fail(layers[layers.size() - 1], io_detail::item_path(lpath, layers.size() - 1),
              "expected action_size (" + std::to_string(p.action_size) + "), got " +
                  std::to_string(widths.back()));
    }
    m.activation = static_cast<Mlp::Activation>(
        rd.choice(net.get("activation"), net.path("activation"), kActivations, "activation"));
    m.negative_slope = rd.number(net.get("negative_slope"), net.path("negative_slope"));
    m.output = static_cast<Mlp::OutputSquash>(
        rd.choice(net.get("output"), net.path("output"), kOutputs, "output"));
    const std::vector<double> scale = rd.numbers(net.get("action_scale"), net.path("action_scale"),
                                                 "an array of action_size numbers");
    if (scale.size() != static_cast<std::size_t>(p.action_size)) {
      rd.fail(net.get("action_scale"), net.path("action_scale"),
              "expected " + std::to_string(p.action_size) +
                  " numbers (one per action: action_size), got " + std::to_string(scale.size()));
    }
    m.action_scale = Eigen::Map<const Eigen::VectorXd>(scale.data(), p.action_size);
    m.observation_clip = rd.positive(net.get("observation_clip"), net.path("observation_clip"));
  }

  // The tensors the widths call for, in their order; the header must list exactly these.
  const std::int64_t n_obs = p.observation_size;
  h.tensors.push_back({"observation_mean", {n_obs}, "observation_size"});
  h.tensors.push_back({"observation_std", {n_obs}, "observation_size"});
  for (std::size_t k = 0; k + 1 < widths.size(); ++k) {
    std::string prefix_k = "layers.";
    prefix_k += std::to_string(k);
    std::string layer_meaning = "network.layers[";
    layer_meaning += std::to_string(k + 1);
    layer_meaning += "], network.layers[";
    layer_meaning += std::to_string(k);
    layer_meaning += ']';
    h.tensors.push_back(
        {prefix_k + ".weight", {widths[k + 1], widths[k]}, "[out, in] = " + layer_meaning});
    h.tensors.push_back(
        {prefix_k + ".bias", {widths[k + 1]}, "network.layers[" + std::to_string(k + 1) + "]"});
  }
  {
    const YAML::Node tensors = field("tensors");
    const std::string tpath = path("tensors");
    if (!tensors.IsSequence()) {
      rd.fail(tensors, tpath,
              "expected an array of {\"name\", \"shape\"} objects, got " +
                  io_detail::describe(tensors));
    }
    const std::size_t n = std::min(tensors.size(), h.tensors.size());
    for (std::size_t i = 0; i < n; ++i) {
      const TensorSpec& want = h.tensors[i];
      const std::string ip = io_detail::item_path(tpath, i);
      const Map t = rd.map(tensors[i], ip, kTensorKeys, "an object with the fields name, shape");
      const std::string name = text(rd, t.required("name"), t.path("name"));
      if (name != want.name) {
        rd.fail(t.get("name"), t.path("name"),
                "expected \"" + want.name + "\", got \"" + name +
                    "\" (observation_mean, observation_std, then layers.<k>.weight and "
                    "layers.<k>.bias for each layer)");
      }
      const YAML::Node shape_node = t.required("shape");
      const std::string spath = t.path("shape");
      if (!shape_node.IsSequence()) {
        rd.fail(shape_node, spath,
                "expected " + shape_text(want.shape) + ", got " + io_detail::describe(shape_node));
      }
      std::vector<std::int64_t> shape;
      for (std::size_t d = 0; d < shape_node.size(); ++d) {
        shape.push_back(
            rd.integer<std::int64_t>(shape_node[d], io_detail::item_path(spath, d), "an integer"));
      }
      if (shape != want.shape) {
        rd.fail(shape_node, spath,
                "expected " + shape_text(want.shape) + " (" + want.meaning + "), got " +
                    shape_text(shape));
      }
    }
    if (tensors.size() != h.tensors.size()) {
      std::string what = "expected ";
      what += std::to_string(h.tensors.size());
      what +=
          " tensors (observation_mean, observation_std and a weight and a bias for each of "
          "the ";
      what += std::to_string(widths.size() - 1);
      what += " layers), got ";
      what += std::to_string(tensors.size());
      what += tensors.size() < h.tensors.size()
                  ? " (" + h.tensors[tensors.size()].name + " is missing)"
                  : std::string(" (one too many from tensors[") + std::to_string(h.tensors.size()) +
                        "])";
      rd.fail(tensors, tpath, what);
    }
  }

  for (const std::string_view key : {std::string_view("env"), std::string_view("training")}) {
    const YAML::Node node = field(key);
    if (!node.IsMap())
      rd.fail(node, path(key), "expected a JSON object, got " + io_detail::describe(node));
    std::string json;
    append_json(node, json);
    (key == "env" ? p.env_json : p.training_json) = std::move(json);
  }

  // The sizes, before anything is allocated for the tensors: at most 2^19 layers of at most
  // 2^16 x 2^16 weights fit a 64-bit count.
  std::uint64_t count = 0;
  for (const TensorSpec& t : h.tensors) count += t.count();
  h.tensor_bytes = 4 * count;
  const std::uint64_t present = file_size - h.tensor_offset;
  require(present >= h.tensor_bytes, src, ": truncated: expected ", h.tensor_bytes,
          " bytes of tensors after the header, got ", present);
  require(present == h.tensor_bytes, src, ": trailing bytes: expected the file to end after ",
          h.tensor_bytes, " bytes of tensors, got ", present, " bytes (", present - h.tensor_bytes,
          " too many)");
  return h;
}

/// Decodes the tensors (`data`: exactly h.tensor_bytes bytes) into h.file.mlp.
void read_tensors(std::string_view data, Header& h, const std::string& src) {
  Mlp& m = h.file.mlp;
  std::size_t at = 0;
  const auto next = [&] {
    const auto v = static_cast<double>(std::bit_cast<float>(u32_le(data, at)));
    at += 4;
    return v;
  };
  const auto bad = [&](const TensorSpec& t, std::int64_t i, std::int64_t j, double v,
                       const char* expected) {
    throw InvalidArgument(t.shape.size() == 1
                              ? detail::concat(src, ": tensor ", t.name, ": element [", i, "] is ",
                                               v, " (expected ", expected, ")")
                              : detail::concat(src, ": tensor ", t.name, ": element [", i, ", ", j,
                                               "] is ", v, " (expected ", expected, ")"));
  };
  const auto vector = [&](const TensorSpec& t, bool positive) {
    Eigen::VectorXd v(t.shape[0]);
    for (std::int64_t i = 0; i < t.shape[0]; ++i) {
      v[i] = next();
      if (!std::isfinite(v[i])) bad(t, i, 0, v[i], "finite numbers");
      if (positive && !(v[i] > 0)) bad(t, i, 0, v[i], "numbers > 0: a standard deviation");
    }
    return v;
  };
  m.observation_mean = vector(h.tensors[0], false);
  m.observation_std = vector(h.tensors[1], true);
  const std::size_t layers = (h.tensors.size() - 2) / 2;
  m.weights.reserve(layers);
  m.biases.reserve(layers);
  for (std::size_t k = 0; k < layers; ++k) {
    const TensorSpec& wt = h.tensors[2 + 2 * k];
    Eigen::MatrixXd w(wt.shape[0], wt.shape[1]);
    for (std::int64_t i = 0; i < wt.shape[0]; ++i) {
      for (std::int64_t j = 0; j < wt.shape[1]; ++j) {  // row-major in the file
        w(i, j) = next();
        if (!std::isfinite(w(i, j))) bad(wt, i, j, w(i, j), "finite numbers");
      }
    }
    m.weights.push_back(std::move(w));
    m.biases.push_back(vector(h.tensors[3 + 2 * k], false));
  }
}

PolicyFile finish(Header& h) {
  validate(h.file);  // everything was checked above; this keeps the reader and the type in step
  return std::move(h.file);
}

}  // namespace

PolicyFile parse_policy(std::string_view bytes, const std::string& source_name) {
  const std::size_t prefix =
      std::min<std::size_t>(bytes.size(), kPreambleBytes + kMaxPolicyHeaderBytes);
  Header h = read_header(bytes.substr(0, prefix), bytes.size(), source_name);
  read_tensors(bytes.substr(h.tensor_offset, h.tensor_bytes), h, source_name);
  return finish(h);
}

PolicyFile read_policy(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InvalidArgument(path + ": cannot read policy file: it is a directory");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidArgument(path + ": cannot open policy file (" + errno_text() + ")");
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  in.seekg(0, std::ios::beg);
  if (!in || end < 0) throw InvalidArgument(path + ": cannot read policy file (not seekable)");
  const auto file_size = static_cast<std::uint64_t>(end);
  // The preamble and the header first (at most 1 MiB), so that the sizes are checked against the
  // file's length before the tensors are read.
  std::string prefix(static_cast<std::size_t>(std::min<std::uint64_t>(
                         file_size, kPreambleBytes + kMaxPolicyHeaderBytes)),
                     '\0');
  in.read(prefix.data(), static_cast<std::streamsize>(prefix.size()));
  if (static_cast<std::size_t>(in.gcount()) != prefix.size())
    throw InvalidArgument(path + ": error while reading policy file");
  Header h = read_header(prefix, file_size, path);
  std::string tensors(static_cast<std::size_t>(h.tensor_bytes), '\0');
  in.clear();
  in.seekg(static_cast<std::streamoff>(h.tensor_offset), std::ios::beg);
  in.read(tensors.data(), static_cast<std::streamsize>(tensors.size()));
  if (!in || static_cast<std::size_t>(in.gcount()) != tensors.size())
    throw InvalidArgument(path + ": error while reading policy file (did it change meanwhile?)");
  read_tensors(tensors, h, path);
  return finish(h);
}

std::string policy_file_bytes(const PolicyFile& p) {
  validate(p);
  const std::string src = p.source.empty() ? std::string("policy") : p.source;
  for (const auto& [name, json] :
       {std::pair<const char*, const std::string*>{"env_json", &p.env_json},
        {"training_json", &p.training_json}}) {
    std::string where = src;
    where += ": ";
    where += name;
    load_json_object(*json, where);
  }
  const Mlp& m = p.mlp;

  std::string observation(1, '[');
  for (std::size_t i = 0; i < p.observation.size(); ++i) {
    if (i) observation += ", ";
    observation += "{\"name\": ";
    observation += json::json_string(p.observation[i].name);
    observation += ", \"size\": ";
    observation += std::to_string(p.observation[i].size);
    observation += '}';
  }
  observation += ']';

  const std::vector<int> widths = m.layer_widths();
  std::string layers(1, '[');
  for (std::size_t i = 0; i < widths.size(); ++i) {
    if (i) layers += ", ";
    layers += std::to_string(widths[i]);
  }
  layers += ']';
  json::JsonObject network(2);
  network.raw("layers", layers)
      .str("activation", kActivationNames[static_cast<int>(m.activation)])
      .num("negative_slope", m.negative_slope)
      .str("output", kOutputSquashNames[static_cast<int>(m.output)])
      .raw("action_scale", json::json_array(m.action_scale))
      .num("observation_clip", m.observation_clip);

  std::string tensors = "[";
  const auto tensor = [&](const std::string& name, const std::string& shape) {
    tensors += tensors.size() > 1 ? ",\n    " : "\n    ";
    tensors += "{\"name\": ";
    tensors += json::json_string(name);
    tensors += ", \"shape\": ";
    tensors += shape;
    tensors += '}';
  };
  const std::string obs_shape = shape_text({p.observation_size});
  tensor("observation_mean", obs_shape);
  tensor("observation_std", obs_shape);
  for (std::size_t k = 0; k < m.weights.size(); ++k) {
    std::string name = "layers.";
    name += std::to_string(k);
    tensor(name + ".weight", shape_text({m.weights[k].rows(), m.weights[k].cols()}));
    tensor(name + ".bias", shape_text({m.biases[k].size()}));
  }
  tensors += "\n  ]";

  json::JsonObject header(0);
  header.str("format", kPolicyFormat)
      .integer("format_version", kPolicyFormatVersion)
      .raw("observation", observation)
      .integer("observation_size", p.observation_size)
      .integer("action_size", p.action_size)
      .str("action_mode", p.action_mode)
      .boolean("normalized_actions", p.normalized_actions)
      .raw("network", network.done())
      .raw("tensors", tensors)
      .raw("env", p.env_json)
      .raw("training", p.training_json);
  std::string header_text = header.done();
  header_text += '\n';

  std::string bytes(kPolicyMagic);
  append_u32_le(bytes, kPolicyFormatVersion);
  append_u32_le(bytes,
                static_cast<std::uint32_t>(std::min<std::size_t>(header_text.size(), 0xFFFFFFFFu)));
  bytes += header_text;
  const auto put = [&](double v) {
    append_u32_le(bytes, std::bit_cast<std::uint32_t>(static_cast<float>(v)));
  };
  for (Eigen::Index i = 0; i < m.observation_mean.size(); ++i) put(m.observation_mean[i]);
  for (Eigen::Index i = 0; i < m.observation_std.size(); ++i) put(m.observation_std[i]);
  for (std::size_t k = 0; k < m.weights.size(); ++k) {
    const Eigen::MatrixXd& w = m.weights[k];
    for (Eigen::Index i = 0; i < w.rows(); ++i)
      for (Eigen::Index j = 0; j < w.cols(); ++j) put(w(i, j));
    for (Eigen::Index i = 0; i < m.biases[k].size(); ++i) put(m.biases[k][i]);
  }
  // What is written must read: float32 rounding (a weight beyond 3.4e38, a standard deviation
  // below 1.4e-45) and a header over 1 MiB are refused here, naming the tensor or the size.
  parse_policy(bytes, src);
  return bytes;
}

void write_policy(const PolicyFile& policy, const std::string& path) {
  std::string bytes;
  try {
    bytes = policy_file_bytes(policy);
  } catch (const InvalidArgument& e) {
    std::string message = path;
    message += ": cannot write the policy: ";
    message += e.what();
    throw InvalidArgument(message);
  }
  write_file_atomically(path, bytes);
}

}  // namespace dronetwin
