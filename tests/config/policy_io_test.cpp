// Policy files (config/policy_io.hpp, docs/policy-format.md): a write/read round trip is bit
// for bit; a header as Python's json.dumps writes it reads; and every malformed file, made by
// editing the bytes of a good one, is refused with a message naming the file, the field or
// tensor, and what was expected against what was found.

#include "dronetwin/config/policy_io.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/noise/random.hpp"
#include "dronetwin/policy/mlp.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::error_of;

// A 6-5-5-4 network with float32 numbers (as a file holds them).
PolicyFile sample() {
  PolicyFile p;
  p.observation = {{"position", 3}, {"velocity", 3}};
  p.observation_size = 6;
  p.action_size = 4;
  p.action_mode = "ctbr";
  p.normalized_actions = true;
  Random rng(11);
  const auto f = [&](double lo, double hi) {
    return static_cast<double>(static_cast<float>(lo + (hi - lo) * rng.uniform()));
  };
  Mlp& m = p.mlp;
  const int widths[] = {6, 5, 5, 4};
  m.observation_mean.resize(6);
  m.observation_std.resize(6);
  for (int i = 0; i < 6; ++i) {
    m.observation_mean[i] = f(-1, 1);
    m.observation_std[i] = f(0.1, 2);
  }
  for (int k = 0; k < 3; ++k) {
    Eigen::MatrixXd w(widths[k + 1], widths[k]);
    for (Eigen::Index i = 0; i < w.size(); ++i) w.data()[i] = f(-1, 1);
    Eigen::VectorXd b(widths[k + 1]);
    for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = f(-0.1, 0.1);
    m.weights.push_back(w);
    m.biases.push_back(b);
  }
  m.activation = Mlp::Activation::kLeakyRelu;
  m.negative_slope = 0.2;
  m.output = Mlp::OutputSquash::kTanh;
  m.action_scale = Eigen::Vector4d(1.0, 2.0, 0.5, 0.25);
  m.observation_clip = 10.0;
  p.env_json = R"({"config": "config/rl/hover.yaml", "task": "hover", "control_rate_hz": 100.0, )"
               R"("nested": {"list": [1, 2.5e-3, true, false, null, "x\"y"], "empty": {}}})";
  p.training_json = R"({"env_steps": 4000000, "seed": 0, "wall_clock_s": 280.5})";
  return p;
}

void expect_same(const PolicyFile& a, const PolicyFile& b) {
  EXPECT_EQ(a.observation, b.observation);
  EXPECT_EQ(a.observation_size, b.observation_size);
  EXPECT_EQ(a.action_size, b.action_size);
  EXPECT_EQ(a.action_mode, b.action_mode);
  EXPECT_EQ(a.normalized_actions, b.normalized_actions);
  EXPECT_EQ(a.env_json, b.env_json);
  EXPECT_EQ(a.training_json, b.training_json);
  const Mlp &x = a.mlp, &y = b.mlp;
  // Bit for bit: == on doubles (no NaN here) and the signs of zeros alike.
  EXPECT_EQ(x.observation_mean, y.observation_mean);
  EXPECT_EQ(x.observation_std, y.observation_std);
  EXPECT_EQ(x.observation_clip, y.observation_clip);
  ASSERT_EQ(x.weights.size(), y.weights.size());
  for (std::size_t k = 0; k < x.weights.size(); ++k) {
    EXPECT_EQ(x.weights[k], y.weights[k]) << k;
    EXPECT_EQ(x.biases[k], y.biases[k]) << k;
  }
  EXPECT_EQ(x.activation, y.activation);
  EXPECT_EQ(x.negative_slope, y.negative_slope);
  EXPECT_EQ(x.output, y.output);
  EXPECT_EQ(x.action_scale, y.action_scale);
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(PolicyIo, WriteThenReadIsBitExact) {
  test::TempDir dir;
  const std::string path = (dir.path() / "hover.dtpolicy").string();
  const PolicyFile p = sample();
  write_policy(p, path);
  const PolicyFile q = read_policy(path);
  expect_same(p, q);
  EXPECT_EQ(q.source, path);
  EXPECT_EQ(q.mlp.layer_widths(), (std::vector<int>{6, 5, 5, 4}));
  // Written again, the bytes are the same; parsed from memory, the same policy.
  const std::string bytes = file_bytes(path);
  EXPECT_EQ(policy_file_bytes(q), bytes);
  expect_same(parse_policy(bytes, "memory"), p);
  // The layout of the doc: magic, version 1, the header length, the header, the tensors.
  ASSERT_GT(bytes.size(), 16u);
  EXPECT_EQ(bytes.substr(0, 8), "DTPOLICY");
  std::uint32_t version, length;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&length, bytes.data() + 12, 4);
  if constexpr (std::endian::native == std::endian::little) {
    EXPECT_EQ(version, 1u);
    EXPECT_EQ(bytes.size(), 16u + length + 4u * (6 + 6 + 30 + 5 + 25 + 5 + 20 + 4));
    float first;
    std::memcpy(&first, bytes.data() + 16 + length, 4);
    EXPECT_EQ(static_cast<double>(first), p.mlp.observation_mean[0]);
  }
  // The same network evaluates the same.
  MlpEvaluator e1(std::make_shared<const Mlp>(p.mlp)), e2(std::make_shared<const Mlp>(q.mlp));
  const double obs[6] = {0.1, -0.2, 1.5, 3.0, -7.0, 0.0};
  double a1[4], a2[4];
  e1.evaluate(obs, a1);
  e2.evaluate(obs, a2);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(a1[i], a2[i]);
}

TEST(PolicyIo, OverwritesAtomicallyAndLeavesTheOldFileOnFailure) {
  test::TempDir dir;
  const std::string path = (dir.path() / "p.dtpolicy").string();
  PolicyFile p = sample();
  write_policy(p, path);
  p.action_mode = "rotor_speeds";
  write_policy(p, path);  // an existing output is replaced
  EXPECT_EQ(read_policy(path).action_mode, "rotor_speeds");
  const std::string before = file_bytes(path);

  PolicyFile bad = sample();
  bad.observation[0].size = 4;
  EXPECT_EQ(error_of([&] { write_policy(bad, path); }),
            path +
                ": cannot write the policy: policy: observation: the piece sizes sum to 7, "
                "observation_size is 6");
  bad = sample();
  bad.mlp.weights[0](0, 0) = 1e39;  // finite in double, infinite in float32
  EXPECT_EQ(error_of([&] { write_policy(bad, path); }),
            path +
                ": cannot write the policy: policy: tensor layers.0.weight: element [0, 0] is inf "
                "(expected finite numbers)");
  bad = sample();
  bad.env_json = "[]";
  EXPECT_EQ(error_of([&] { write_policy(bad, path); }),
            path +
                ": cannot write the policy: policy: env_json: line 1, column 1: expected a JSON "
                "object (starting with '{'), got '['");
  bad = sample();
  bad.training_json = R"({"a": 1}, "format": "x")";
  EXPECT_NE(error_of([&] { write_policy(bad, path); })
                .find("training_json: line 1, column 9: unexpected ',' after the end of the "
                      "JSON object"),
            std::string::npos);
  EXPECT_EQ(file_bytes(path), before);  // untouched
  // No temporary file is left behind.
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);

  const std::string missing = (dir.path() / "no" / "p.dtpolicy").string();
  EXPECT_NE(error_of([&] { write_policy(sample(), missing); }).find(missing), std::string::npos);
  EXPECT_EQ(error_of([&] { read_policy(missing); }),
            missing + ": cannot open policy file (No such file or directory)");
  EXPECT_EQ(error_of([&] { read_policy(dir.path().string()); }),
            dir.path().string() + ": cannot read policy file: it is a directory");
}

// ---- a header as Python writes it -----------------------------------------------------------

std::string preamble(std::size_t header_length) {
  std::string out = "DTPOLICY";
  for (const std::uint32_t v : {1u, static_cast<std::uint32_t>(header_length)})
    for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
  return out;
}

std::string floats(const std::vector<float>& values) {
  std::string out;
  for (const float v : values) {
    const auto bits = std::bit_cast<std::uint32_t>(v);
    for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((bits >> (8 * k)) & 0xFF));
  }
  return out;
}

// json.dumps(header, indent=1) of a 2-3-1 network (python/dronetwin/policy.py).
const char* const kPythonHeader = R"({
 "format": "dronetwin.policy",
 "format_version": 1,
 "observation": [
  {
   "name": "target_relative",
   "size": 2
  }
 ],
 "observation_size": 2,
 "action_size": 1,
 "action_mode": "generalized_force",
 "normalized_actions": false,
 "network": {
  "layers": [
   2,
   3,
   1
  ],
  "activation": "tanh",
  "negative_slope": 0.2,
  "output": "identity",
  "action_scale": [
   1.5
  ],
  "observation_clip": 5.0
 },
 "tensors": [
  {
   "name": "observation_mean",
   "shape": [
    2
   ]
  },
  {
   "name": "observation_std",
   "shape": [
    2
   ]
  },
  {
   "name": "layers.0.weight",
   "shape": [
    3,
    2
   ]
  },
  {
   "name": "layers.0.bias",
   "shape": [
    3
   ]
  },
  {
   "name": "layers.1.weight",
   "shape": [
    1,
    3
   ]
  },
  {
   "name": "layers.1.bias",
   "shape": [
    1
   ]
  }
 ],
 "env": {
  "config": "config/rl/hover.yaml",
  "task": "hover",
  "control_rate_hz": 100.0,
  "nested": {"a": [1e-05, -0.0, "\u00e9\n"], "b": null}
 },
 "training": {}
})";

TEST(PolicyIo, ReadsAHeaderAsPythonWritesIt) {
  const std::string header = kPythonHeader;
  const std::string bytes =
      preamble(header.size()) + header +
      floats({0.5f, -1.0f, 2.0f, 0.25f, 1, 2, 3, 4, 5, 6, 0.1f, 0.2f, 0.3f, -1, 0.5f, 2, 0.75f});
  const PolicyFile p = parse_policy(bytes, "py.dtpolicy");
  EXPECT_EQ(p.source, "py.dtpolicy");
  EXPECT_EQ(p.observation, (std::vector<PolicyObservationPiece>{{"target_relative", 2}}));
  EXPECT_EQ(p.action_mode, "generalized_force");
  EXPECT_FALSE(p.normalized_actions);
  EXPECT_EQ(p.mlp.activation, Mlp::Activation::kTanh);
  EXPECT_EQ(p.mlp.output, Mlp::OutputSquash::kIdentity);
  EXPECT_EQ(p.mlp.observation_clip, 5.0);
  EXPECT_EQ(p.mlp.action_scale, Eigen::VectorXd::Constant(1, 1.5));
  Eigen::MatrixXd w0(3, 2);
  w0 << 1, 2, 3, 4, 5, 6;  // row-major in the file
  EXPECT_EQ(p.mlp.weights[0], w0);
  Eigen::MatrixXd w1(1, 3);
  w1 << -1, 0.5, 2;
  EXPECT_EQ(p.mlp.weights[1], w1);
  EXPECT_EQ(p.mlp.biases[1], Eigen::VectorXd::Constant(1, 0.75));
  EXPECT_EQ(p.env_json,
            "{\"config\": \"config/rl/hover.yaml\", \"task\": \"hover\", \"control_rate_hz\": "
            "100.0, \"nested\": {\"a\": [1e-05, -0.0, \"\xc3\xa9\\n\"], \"b\": null}}");
  EXPECT_EQ(p.training_json, "{}");
  // a = 1.5 * (W1 tanh(W0 h + b0) + b1), h = (o - mean) / std.
  MlpEvaluator e(std::make_shared<const Mlp>(p.mlp));
  const double o[2] = {1.0, 0.0};
  const double h0 = (1.0 - 0.5) / 2.0, h1 = (0.0 + 1.0) / 0.25;
  const double z = -1 * std::tanh(1 * h0 + 2 * h1 + 0.1f) +
                   0.5 * std::tanh(3 * h0 + 4 * h1 + 0.2f) + 2 * std::tanh(5 * h0 + 6 * h1 + 0.3f) +
                   0.75;
  double a;
  e.evaluate(o, &a);
  EXPECT_NEAR(a, 1.5 * z, 1e-12);
}

// ---- malformed files --------------------------------------------------------------------------

std::uint32_t header_length(const std::string& bytes) {
  std::uint32_t v = 0;
  for (int k = 0; k < 4; ++k)
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[12 + k])) << (8 * k);
  return v;
}

void set_u32(std::string& bytes, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) bytes[at + k] = static_cast<char>((v >> (8 * k)) & 0xFF);
}

/// The file with its header text replaced (and the length fixed up).
std::string with_header(const std::string& bytes, const std::string& header) {
  const std::uint32_t h = header_length(bytes);
  std::string out = bytes.substr(0, 16) + header + bytes.substr(16 + h);
  set_u32(out, 12, static_cast<std::uint32_t>(header.size()));
  return out;
}

/// The file with the first `from` of its header replaced by `to`.
std::string edit(const std::string& bytes, const std::string& from, const std::string& to) {
  std::string header = bytes.substr(16, header_length(bytes));
  const std::size_t at = header.find(from);
  EXPECT_NE(at, std::string::npos) << "not in the header: " << from << "\n" << header;
  if (at == std::string::npos) return bytes;
  header.replace(at, from.size(), to);
  return with_header(bytes, header);
}

/// The file with float number `index` of the tensors set to `v`.
std::string set_float(std::string bytes, std::size_t index, float v) {
  set_u32(bytes, 16 + header_length(bytes) + 4 * index, std::bit_cast<std::uint32_t>(v));
  return bytes;
}

struct BadCase {
  const char* what;
  std::string bytes;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(PolicyIo, EveryMalformedFileIsNamedWithWhatWasExpected) {
  const std::string good = policy_file_bytes(sample());
  ASSERT_NO_THROW(parse_policy(good, "t.dtpolicy"));
  const std::size_t h = header_length(good);
  const std::size_t tensor_bytes = good.size() - 16 - h;  // 4 * 101 floats
  ASSERT_EQ(tensor_bytes, 4u * 101);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const auto bytes_with = [&](std::size_t at, std::uint32_t v) {
    std::string b = good;
    set_u32(b, at, v);
    return b;
  };
  // A hostile header: 100 layers of 65536 x 65536 in a file of a few KB.
  std::string hostile_layers = "[6";
  for (int k = 0; k < 100; ++k) hostile_layers += ", 65536";
  hostile_layers += ", 4]";
  std::string hostile_tensors =
      R"([{"name": "observation_mean", "shape": [6]}, {"name": "observation_std", "shape": [6]})";
  std::vector<int> widths = {6};
  for (int k = 0; k < 100; ++k) widths.push_back(65536);
  widths.push_back(4);
  for (std::size_t k = 0; k + 1 < widths.size(); ++k) {
    hostile_tensors += ", {\"name\": \"layers." + std::to_string(k) + ".weight\", \"shape\": [" +
                       std::to_string(widths[k + 1]) + ", " + std::to_string(widths[k]) + "]}";
    hostile_tensors += ", {\"name\": \"layers." + std::to_string(k) + ".bias\", \"shape\": [" +
                       std::to_string(widths[k + 1]) + "]}";
  }
  hostile_tensors += "]";
  std::string hostile = edit(good, "\"layers\": [6, 5, 5, 4]", "\"layers\": " + hostile_layers);
  {
    const std::string header = hostile.substr(16, header_length(hostile));
    const std::size_t from = header.find("\"tensors\": [");
    const std::size_t to = header.find("\n  ]", from) + 4;
    hostile = with_header(
        hostile, header.substr(0, from) + "\"tensors\": " + hostile_tensors + header.substr(to));
  }
  std::string deep = "{\"a\": ";
  for (int k = 0; k < 70; ++k) deep += "[";
  for (int k = 0; k < 70; ++k) deep += "]";
  deep += "}";

  const std::vector<BadCase> cases = {
      {"magic",
       "X" + good.substr(1),
       {"t.dtpolicy: not a dronetwin policy file: expected the magic \"DTPOLICY\" in bytes 0-7, "
        "got \"XTPOLICY\""}},
      {"empty", "", {"t.dtpolicy: not a dronetwin policy file", "got a file of 0 bytes"}},
      {"preamble cut",
       good.substr(0, 12),
       {"t.dtpolicy: truncated: expected at least 16 bytes (magic, format version, header "
        "length), got 12"}},
      {"version",
       bytes_with(8, 2),
       {"t.dtpolicy: format version: this dronetwin reads version 1, got 2"}},
      {"header over 1 MiB",
       bytes_with(12, (1u << 20) + 1),
       {"t.dtpolicy: header length: expected at most 1048576 bytes (1 MiB), got 1048577"}},
      {"header past the end",
       bytes_with(12, static_cast<std::uint32_t>(good.size())),
       {"t.dtpolicy: truncated: the header length is " + std::to_string(good.size()) +
        " bytes, but only " + std::to_string(good.size() - 16) +
        " bytes follow the 16-byte preamble"}},
      {"not UTF-8",
       edit(good, "position", "posi\xfftion"),
       {"t.dtpolicy: header: line 4, column", "expected UTF-8 text (as JSON is), got byte 0xFF"}},
      {"empty header",
       with_header(good, ""),
       {"t.dtpolicy: header: line 1, column 1: expected a JSON object, got no value"}},
      {"not an object",
       with_header(good, "[1]"),
       {"t.dtpolicy: header: line 1, column 1: expected a JSON object (starting with '{'), got "
        "'['"}},
      {"text after the object",
       with_header(good, good.substr(16, h) + " {}"),
       {"t.dtpolicy: header:", "unexpected '{' after the end of the JSON object"}},
      {"missing comma",
       edit(good, "\"format_version\": 1,", "\"format_version\": 1"),
       {"t.dtpolicy: header: line", "JSON syntax error"}},
      {"trailing comma",
       edit(good, "\"seed\": 0,", "\"seed\": 0,}, \"x\": {"),
       {"t.dtpolicy: header: line", "a comma before '}' (JSON has no trailing commas)"}},
      {"comment",
       edit(good, "\"format_version\": 1,", "\"format_version\": 1, # one"),
       {"t.dtpolicy: header: line 3, column 24: unexpected '#' (not JSON)"}},
      {"single quotes",
       edit(good, "\"ctbr\"", "'ctbr'"),
       {"t.dtpolicy: header: line", "a single quote (JSON strings are in double quotes)"}},
      {"YAML escape",
       edit(good, "\"ctbr\"", "\"ct\\xbr\""),
       {"t.dtpolicy: header: line", "escape \\x is not JSON"}},
      {"unterminated string",
       with_header(good, "{\"format\": \"dronetwin"),
       {"t.dtpolicy: header:", "the text ends inside a string"}},
      {"unclosed object",
       with_header(good, "{\"format\": {"),
       {"t.dtpolicy: header:", "the text ends inside 2 unclosed object(s) or array(s)"}},
      {"too deep",
       edit(good, "\"training\": {", "\"training\": " + deep + ", \"t\": {"),
       {"t.dtpolicy: header:", "objects and arrays nested deeper than 64 levels"}},
      {"unquoted word",
       edit(good, "\"ctbr\"", "ctbr"),
       {"t.dtpolicy: header: action_mode: expected a JSON value (a string in double quotes, a "
        "number, true, false or null), got 'ctbr'"}},
      {"YAML boolean",
       edit(good, "true", "True"),
       {"t.dtpolicy: header: normalized_actions: expected a JSON value", "got 'True'"}},
      {"NaN number",
       edit(good, "\"observation_clip\": 10", "\"observation_clip\": NaN"),
       {"t.dtpolicy: header: network.observation_clip: expected a JSON value", "got 'NaN'"}},
      {"unquoted key",
       edit(good, "\"format_version\"", "format_version"),
       {"t.dtpolicy: header: expected keys to be strings in double quotes, got 'format_version'"}},
      {"duplicate key",
       edit(good, "\"action_size\": 4,", "\"action_size\": 4, \"action_size\": 4,"),
       {"t.dtpolicy: header: duplicate key 'action_size'"}},
      {"format",
       edit(good, "\"dronetwin.policy\"", "\"dronetwin.run_log\""),
       {"t.dtpolicy: header: format: expected \"dronetwin.policy\", got \"dronetwin.run_log\""}},
      {"format_version",
       edit(good, "\"format_version\": 1", "\"format_version\": 2"),
       {"t.dtpolicy: header: format_version: expected 1 (the version in the preamble), got 2"}},
      {"unknown key",
       edit(good, "\"format_version\": 1,", "\"format_version\": 1, \"extra\": 2,"),
       {"t.dtpolicy: header: unknown key 'extra'", "(valid keys: format, format_version"}},
      {"unknown network key",
       edit(good, "\"observation_clip\": 10", "\"observation_clip\": 10, \"dropout\": 0.1"),
       {"t.dtpolicy: header: network: unknown key 'dropout'"}},
      {"missing key",
       edit(good, "\"normalized_actions\": true,", ""),
       {"t.dtpolicy: header: missing required key 'normalized_actions'"}},
      {"missing network key",
       edit(good, "\"output\": \"tanh\",", ""),
       {"t.dtpolicy: header: network: missing required key 'output'"}},
      {"observation sizes",
       edit(good, "\"size\": 3}]", "\"size\": 2}]"),
       {"t.dtpolicy: header: observation: the piece sizes sum to 5, observation_size is 6"}},
      {"observation piece",
       edit(good, "{\"name\": \"velocity\", ", "{\"nam\": \"velocity\", "),
       {"t.dtpolicy: header: observation[1]: unknown key 'nam'; did you mean 'name'?"}},
      {"first width",
       edit(good, "\"layers\": [6,", "\"layers\": [7,"),
       {"t.dtpolicy: header: network.layers[0]: expected observation_size (6), got 7"}},
      {"last width",
       edit(good, "5, 5, 4]", "5, 5, 3]"),
       {"t.dtpolicy: header: network.layers[3]: expected action_size (4), got 3"}},
      {"width too large",
       edit(good, "[6, 5, 5, 4]", "[6, 70000, 5, 4]"),
       {"t.dtpolicy: header: network.layers[1]: expected an integer in [1, 65536], got 70000"}},
      {"width not an integer",
       edit(good, "[6, 5, 5, 4]", "[6, 5.5, 5, 4]"),
       {"t.dtpolicy: header: network.layers[1]: expected an integer in [1, 65536], got '5.5'"}},
      {"one layer",
       edit(good, "[6, 5, 5, 4]", "[6]"),
       {"t.dtpolicy: header: network.layers: expected an array of at least 2 widths"}},
      {"width against the tensors",
       edit(good, "[6, 5, 5, 4]", "[6, 6, 5, 4]"),
       {"t.dtpolicy: header: tensors[2].shape: expected [6, 6] ([out, in] = network.layers[1], "
        "network.layers[0]), got [5, 6]"}},
      {"tensor order",
       edit(edit(good, "\"layers.0.weight\"", "\"layers.0.bias_\""), "\"layers.0.bias\"",
            "\"layers.0.weight\""),
       {"t.dtpolicy: header: tensors[2].name: expected \"layers.0.weight\", got "
        "\"layers.0.bias_\""}},
      {"tensor shape",
       edit(good, "\"shape\": [5, 5]", "\"shape\": [25]"),
       {"t.dtpolicy: header: tensors[4].shape: expected [5, 5] ([out, in] = network.layers[2], "
        "network.layers[1]), got [25]"}},
      {"tensor missing",
       edit(good, ",\n    {\"name\": \"layers.2.bias\", \"shape\": [4]}", ""),
       {"t.dtpolicy: header: tensors: expected 8 tensors (observation_mean, observation_std and "
        "a weight and a bias for each of the 3 layers), got 7 (layers.2.bias is missing)"}},
      {"tensor extra",
       edit(good, "{\"name\": \"layers.2.bias\", \"shape\": [4]}",
            "{\"name\": \"layers.2.bias\", \"shape\": [4]}, {\"name\": \"x\", \"shape\": [1]}"),
       {"t.dtpolicy: header: tensors: expected 8 tensors", "got 9"}},
      {"action_scale size",
       edit(good, "[1, 2, 0.5, 0.25]", "[1, 2, 0.5]"),
       {"t.dtpolicy: header: network.action_scale: expected 4 numbers (one per action: "
        "action_size), got 3"}},
      {"activation",
       edit(good, "\"leaky_relu\"", "\"swish\""),
       {"t.dtpolicy: header: network.activation: unknown activation 'swish'",
        "leaky_relu, relu, tanh"}},
      {"output",
       edit(good, "\"output\": \"tanh\"", "\"output\": \"sigmoid\""),
       {"t.dtpolicy: header: network.output: unknown output 'sigmoid'"}},
      {"action mode",
       edit(good, "\"ctbr\"", "\"thrust\""),
       {"t.dtpolicy: header: action_mode: unknown action mode 'thrust'"}},
      {"observation_clip",
       edit(good, "\"observation_clip\": 10", "\"observation_clip\": 0"),
       {"t.dtpolicy: header: network.observation_clip:", "got 0"}},
      {"env not an object",
       edit(good, "\"env\": " + sample().env_json, "\"env\": [1]"),
       {"t.dtpolicy: header: env: expected a JSON object, got a sequence of 1 item"}},
      {"truncated",
       good.substr(0, good.size() - 4),
       {"t.dtpolicy: truncated: expected " + std::to_string(tensor_bytes) +
        " bytes of tensors after the header, got " + std::to_string(tensor_bytes - 4)}},
      {"trailing bytes",
       good + std::string(1, '\0'),
       {"t.dtpolicy: trailing bytes: expected the file to end after " +
        std::to_string(tensor_bytes) + " bytes of tensors, got " +
        std::to_string(tensor_bytes + 1) + " bytes (1 too many)"}},
      {"hostile widths",
       hostile,
       {"t.dtpolicy: truncated: expected " +
        std::to_string(
            4ull * (12 + 65536ull * 6 + 65536 + 99 * (65536ull * 65536 + 65536) + 4 * 65536 + 4)) +
        " bytes of tensors after the header, got " + std::to_string(tensor_bytes)}},
      // Floats: 6 mean, 6 std, then layers.0.weight [5, 6], layers.0.bias [5],
      // layers.1.weight [5, 5] from float 47.
      {"NaN weight",
       set_float(good, 47 + 2 * 5 + 3, nan),
       {"t.dtpolicy: tensor layers.1.weight: element [2, 3] is nan (expected finite numbers)"}},
      {"infinite mean",
       set_float(good, 1, -inf),
       {"t.dtpolicy: tensor observation_mean: element [1] is -inf (expected finite numbers)"}},
      {"zero std",
       set_float(good, 6 + 2, 0.0f),
       {"t.dtpolicy: tensor observation_std: element [2] is 0 (expected numbers > 0: a "
        "standard deviation)"}},
      {"negative std",
       set_float(good, 6 + 5, -1.0f),
       {"t.dtpolicy: tensor observation_std: element [5] is -1"}},
      {"infinite bias",
       set_float(good, 100, inf),
       {"t.dtpolicy: tensor layers.2.bias: element [3] is inf"}},
  };
  for (const BadCase& c : cases) {
    const std::string message = error_of([&] { parse_policy(c.bytes, "t.dtpolicy"); });
    for (const std::string& part : c.expected)
      EXPECT_NE(message.find(part), std::string::npos)
          << c.what << ":\n  message: " << message << "\n  expected: " << part;
  }

  // read_policy says the same, naming the path.
  test::TempDir dir;
  const std::string path = (dir.path() / "bad.dtpolicy").string();
  {
    std::ofstream out(path, std::ios::binary);
    out << good.substr(0, good.size() - 4);
  }
  EXPECT_EQ(error_of([&] { read_policy(path); }),
            path + ": truncated: expected " + std::to_string(tensor_bytes) +
                " bytes of tensors after the header, got " + std::to_string(tensor_bytes - 4));
  {
    std::ofstream out(path, std::ios::binary);
    out << hostile;
  }
  EXPECT_NE(error_of([&] { read_policy(path); }).find(path + ": truncated: expected "),
            std::string::npos);
}

TEST(PolicyIo, NullAndMissingValuesInProvenance) {
  const std::string good = policy_file_bytes(sample());
  EXPECT_NO_THROW(parse_policy(edit(good, "\"seed\": 0", "\"seed\": null"), "t.dtpolicy"));
  for (const char* spelling : {"Null", "NULL"}) {
    const std::string message = error_of([&] {
      parse_policy(edit(good, "\"seed\": 0", std::string("\"seed\": ") + spelling), "t");
    });
    EXPECT_NE(message.find("t: header: training.seed: expected a JSON value"), std::string::npos)
        << message;
  }
  const std::string missing =
      error_of([&] { parse_policy(edit(good, "\"seed\": 0", "\"seed\": "), "t"); });
  EXPECT_NE(missing.find("t: header:"), std::string::npos) << missing;
}

}  // namespace
}  // namespace dronetwin
