#pragma once
// Strict YAML reading shared by the file loaders of src/io (experiment files, vehicle models,
// controller configs). Private to src/io: not installed, and the only place besides the loaders'
// .cpp files that sees yaml-cpp.
//
// Every error is an InvalidArgument with the text
//
//   <source>: <path>: <message> (line n)
//
// where <source> is the file (or the name that stands for it), <path> the field
// ("input.segments[1].start_s"; left out for the document itself), <message> says what was
// expected and what was found ("expected a number, got the string \"1.0\""), and the line is
// added when yaml-cpp knows it. Unknown keys are reported with the closest valid key and the full
// list; duplicate keys are errors.
//
//   const io_detail::Reader rd(source_name);
//   const YAML::Node root = rd.parse(yaml_text, "a map of controller settings");
//   const io_detail::Map top = rd.map(root, "", kTopLevelKeys, "a map of controller settings");
//   const double kp = rd.number(top.required("kp"), top.path("kp"));
//   if (top.has("limit_N"))
//     limit = rd.fixed<3>(top.get("limit_N"), top.path("limit_N"), "x, y, z in N");
//
// Scalars: numbers and booleans are plain scalars (untagged, or tagged with one of the core
// schema's !!float, !!int, !!bool); a quoted or !!str scalar is a string and never a number. A
// number is a YAML 1.2 core-schema float (docs/model-format.md, "Numbers"); a boolean is
// true/false (also True/TRUE/False/FALSE), never yes/no/on/off.

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace dronetwin::io_detail {

/// The valid names of a map's keys or of a choice: a std::array or std::vector of string_view.
using NameList = std::span<const std::string_view>;

// ---- messages ---------------------------------------------------------------------------------

/// Field paths: child_path("input", "type") == "input.type" (just "type" for the document
/// itself, parent ""); item_path("rotors", 2) == "rotors[2]".
std::string child_path(const std::string& parent, std::string_view key);
std::string item_path(const std::string& parent, std::size_t i);

/// "a, b, c".
std::string name_list(NameList names);

/// What a node is, for "got ..." in messages: "'1.5'", "the string \"1.5\"", "nothing (null)",
/// "a sequence of 3 items", "a map".
std::string describe(const YAML::Node& node);

/// A number for a message, with up to 17 significant digits ("0.5", "0.10000000000000001").
std::string format_number(double v);

// ---- scalar grammar ---------------------------------------------------------------------------

/// True for a scalar that may hold a number or a bool: untagged (plain) or tagged !!float, !!int
/// or !!bool. A quoted "1.5" or a !!str scalar is a string. describe() quotes a plain scalar's
/// text and calls anything else a string.
bool is_plain(const YAML::Node& node);

/// YAML 1.2 core-schema float, including .inf / -.inf / .nan (in the spellings of the schema).
/// Locale-independent and correctly rounded. False if `text` is not such a number.
bool parse_number(std::string_view text, double& out);

/// Decimal integer with an optional sign that fits Int. Defined for the standard integer types.
template <class Int>
bool parse_integer(std::string_view text, Int& out);

/// Throws InvalidArgument "<source>: line L, column C: expected UTF-8 text (as <format> is), got
/// byte 0xNN" at the first byte of `text` that does not belong to a well-formed UTF-8 sequence
/// (an overlong form, a surrogate or a code point past U+10FFFF included). Checked before
/// yaml-cpp sees a text, so that a file in another encoding, or a corrupted one, is named as such.
void require_utf8(std::string_view text, const std::string& source, std::string_view format);
/// True when `text` is well-formed UTF-8.
bool is_utf8(std::string_view text);
/// The message for a quoted scalar whose escapes decode to something that is not UTF-8: yaml-cpp
/// 0.7 turns the YAML escapes \N and \_ into the single bytes 0x85 and 0xA0, which nothing that
/// reads the string back (a log sidecar, say) accepts (found by the fuzzers).
inline constexpr const char* kNotUtf8AfterEscapes =
    "the string is not UTF-8 once its escapes are decoded (yaml-cpp decodes \\N and \\_ to "
    "single bytes; write the characters themselves or \\u0085, \\u00a0)";

/// The JSON document of `json_text` (a file's text; `source_name` names it in messages), parsed
/// by yaml-cpp (JSON is YAML 1.2 flow syntax) after checks that keep YAML's extensions out:
/// UTF-8, no raw control characters (inside strings they are escaped, outside only tab, line
/// feed and carriage return), no single quotes and only JSON's escapes. Errors are
/// InvalidArgument "<source>: line L, column C: ...", and "JSON syntax error" for yaml-cpp's.
/// (Not Reader::parse: its messages speak of YAML.)
YAML::Node load_json(const std::string& json_text, const std::string& source_name);

// ---- files ------------------------------------------------------------------------------------

/// The whole file. `what` names it in errors: "<path>: cannot open <what> (<reason>)".

// ---- reader -----------------------------------------------------------------------------------

class Map;

/// Whether Reader::number() and everything built on it accept .inf and .nan.
enum class NonFinite {
  kReject,  ///< "expected a finite number, got .nan"
  kAllow,   ///< read as numbers (for files whose validation names non-finite values later)
};

/// Reads the nodes of one source; every method throws InvalidArgument naming the source and the
/// path it is given.
class Reader {
 public:
  explicit Reader(std::string source, NonFinite non_finite = NonFinite::kReject);

  const std::string& source() const { return source_; }

  /// Throws "<source>: <path>: <message> (line n)"; the line is left out when `at` is undefined
  /// or null (yaml-cpp marks an empty value at the following token, often on the next line).
  [[noreturn]] void fail(const YAML::Node& at, const std::string& path,
                         const std::string& message) const;
  /// Same, with no line.
  [[noreturn]] void fail(const std::string& path, const std::string& message) const;

  /// The single YAML document of `yaml_text`. A syntax error, an empty text ("empty document;
  /// expected <expected>") and a second document are errors.
  YAML::Node parse(const std::string& yaml_text, const std::string& expected) const;

  /// The entries of a map node at `path`. Fails unless `node` is a map ("expected <expected>,
  /// got ..."), on a key that is not a name, on a duplicate key and on a key not in `allowed`.
  /// The Map refers to this Reader: it must not outlive it.
  Map map(const YAML::Node& node, const std::string& path, NameList allowed,
          const std::string& expected) const;

  /// A number (finite unless the reader was made with NonFinite::kAllow).
  double number(const YAML::Node& node, const std::string& path) const;
  /// A number > 0.
  double positive(const YAML::Node& node, const std::string& path) const;
  /// An integer that fits Int; `what` says which ("an integer >= 1") in "expected <what>, got ...".
  template <class Int>
  Int integer(const YAML::Node& node, const std::string& path, const std::string& what) const;
  /// true or false (also True, TRUE, False, FALSE).
  bool boolean(const YAML::Node& node, const std::string& path) const;
  /// A non-empty string (a plain scalar is a string too).
  std::string string(const YAML::Node& node, const std::string& path) const;
  /// One of `names`, plain or quoted; returns its index. `what` names the kind ("integrator") in
  /// "unknown integrator 'rk5'; did you mean 'rk4'? (valid: rk4, euler)".
  std::size_t choice(const YAML::Node& node, const std::string& path, NameList names,
                     const std::string& what) const;
  /// A sequence of numbers of any length; `expected` describes it for the not-a-sequence error.
  std::vector<double> numbers(const YAML::Node& node, const std::string& path,
                              const std::string& expected) const;
  /// Exactly N numbers; `meaning` explains them: "expected 3 numbers (x, y, z in m), got 2". An
  /// empty `meaning` leaves out the parentheses.
  template <int N>
  Eigen::Matrix<double, N, 1> fixed(const YAML::Node& node, const std::string& path,
                                    const std::string& meaning) const;

 private:
  std::string source_;
  NonFinite non_finite_;
};

/// The checked entries of one YAML map (made by Reader::map), with the map's path for messages.
class Map {
 public:
  bool has(std::string_view key) const { return entries_.find(key) != entries_.end(); }
  /// The value of an optional key, or an undefined node when it is absent.
  YAML::Node get(std::string_view key) const;
  /// The value of a required key; fails "missing required key '<key>'" when it is absent (with
  /// the map's line, except for the document itself).
  YAML::Node required(std::string_view key) const;
  /// The path of a key of this map, for reading its value.
  std::string path(std::string_view key) const { return child_path(path_, key); }

 private:
  friend class Reader;
  Map(const Reader& reader, YAML::Node node, std::string path,
      std::map<std::string, YAML::Node, std::less<>> entries);

  const Reader* reader_;
  YAML::Node node_;
  std::string path_;
  std::map<std::string, YAML::Node, std::less<>> entries_;
};

// ---- templates --------------------------------------------------------------------------------

template <class Int>
Int Reader::integer(const YAML::Node& node, const std::string& path,
                    const std::string& what) const {
  Int v{};
  if (!is_plain(node) || !parse_integer(node.Scalar(), v))
    fail(node, path, "expected " + what + ", got " + describe(node));
  return v;
}

template <int N>
Eigen::Matrix<double, N, 1> Reader::fixed(const YAML::Node& node, const std::string& path,
                                          const std::string& meaning) const {
  const std::string expected =
      std::to_string(N) + " numbers" + (meaning.empty() ? "" : " (" + meaning + ")");
  if (!node.IsSequence()) fail(node, path, "expected " + expected + ", got " + describe(node));
  if (node.size() != static_cast<std::size_t>(N))
    fail(node, path, "expected " + expected + ", got " + std::to_string(node.size()));
  Eigen::Matrix<double, N, 1> out;
  for (std::size_t i = 0; i < static_cast<std::size_t>(N); ++i)
    out[static_cast<Eigen::Index>(i)] = number(node[i], item_path(path, i));
  return out;
}

}  // namespace dronetwin::io_detail
