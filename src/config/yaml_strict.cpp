// Strict YAML reading shared by the loaders of src/io (see yaml_strict.hpp).
#include "yaml_strict.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <system_error>
#include <utility>

#include "dronetwin/core/error.hpp"

namespace dronetwin::io_detail {
namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // Levenshtein distance, one row at a time.
  std::vector<std::size_t> previous(b.size() + 1), current(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) previous[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    current[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitute = previous[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      current[j] = std::min({previous[j] + 1, current[j - 1] + 1, substitute});
    }
    std::swap(previous, current);
  }
  return previous[b.size()];
}

/// "; did you mean 'x'?" for the closest name, if it is close enough to be a typo.
std::string did_you_mean(std::string_view unknown, NameList valid) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view name : valid) {
    const std::size_t d = edit_distance(unknown, name);
    if (d < best_distance) best_distance = d, best = name;
  }
  const std::size_t tolerance = std::max<std::size_t>(2, unknown.size() / 3);
  if (best.empty() || best_distance > tolerance) return {};
  return "; did you mean '" + std::string(best) + "'?";
}

}  // namespace

// ---- messages ---------------------------------------------------------------------------------

std::string child_path(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string item_path(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

std::string name_list(NameList names) {
  std::string out;
  for (std::string_view n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
    case YAML::NodeType::Null:
      return "nothing (null)";
    case YAML::NodeType::Scalar:
      return is_plain(node) ? "'" + node.Scalar() + "'" : "the string \"" + node.Scalar() + "\"";
    case YAML::NodeType::Sequence:
      return "a sequence of " + std::to_string(node.size()) +
             (node.size() == 1 ? " item" : " items");
    case YAML::NodeType::Map:
      return "a map";
  }
  return "an unknown node";
}

std::string format_number(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

// ---- scalar grammar ---------------------------------------------------------------------------

bool is_plain(const YAML::Node& node) {
  if (!node.IsScalar()) return false;
  const std::string& tag = node.Tag();
  return tag == "?" || tag == "tag:yaml.org,2002:float" || tag == "tag:yaml.org,2002:int" ||
         tag == "tag:yaml.org,2002:bool";
}

// [-+]?(digits[.digits*]|.digits)([eE][-+]?digits)?, or [-+]?.inf and .nan in the three spellings
// of the schema.
bool parse_number(std::string_view text, double& out) {
  std::string_view body = text;
  const bool negative = !body.empty() && body.front() == '-';
  if (!body.empty() && (body.front() == '-' || body.front() == '+')) body.remove_prefix(1);
  if (body == ".inf" || body == ".Inf" || body == ".INF") {
    out = negative ? -std::numeric_limits<double>::infinity()
                   : std::numeric_limits<double>::infinity();
    return true;
  }
  if (text == ".nan" || text == ".NaN" || text == ".NAN") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  // Check the grammar here: from_chars would also accept "inf", "nan" and "infinity".
  std::size_t i = 0, digits = 0;
  for (; i < body.size() && is_digit(body[i]); ++i) ++digits;
  if (i < body.size() && body[i] == '.') {
    for (++i; i < body.size() && is_digit(body[i]); ++i) ++digits;
  }
  if (digits == 0) return false;
  if (i < body.size() && (body[i] == 'e' || body[i] == 'E')) {
    ++i;
    if (i < body.size() && (body[i] == '+' || body[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    for (; i < body.size() && is_digit(body[i]); ++i) ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  if (i != body.size()) return false;
  double v = 0.0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v);
  if (r.ec != std::errc{} || r.ptr != body.data() + body.size()) return false;
  out = negative ? -v : v;
  return true;
}

template <class Int>
bool parse_integer(std::string_view text, Int& out) {
  std::string_view digits = text;
  if (!digits.empty() && (digits.front() == '+' || digits.front() == '-')) digits.remove_prefix(1);
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), is_digit)) return false;
  // from_chars takes a leading '-' (and fails on it for an unsigned Int) but not '+'.
  const std::string_view signed_digits = text.front() == '+' ? digits : text;
  const auto r =
      std::from_chars(signed_digits.data(), signed_digits.data() + signed_digits.size(), out);
  return r.ec == std::errc{} && r.ptr == signed_digits.data() + signed_digits.size();
}

template bool parse_integer(std::string_view, int&);
template bool parse_integer(std::string_view, long&);
template bool parse_integer(std::string_view, long long&);
template bool parse_integer(std::string_view, unsigned&);
template bool parse_integer(std::string_view, unsigned long&);
template bool parse_integer(std::string_view, unsigned long long&);

namespace {
/// The first byte of `text` that is not part of a well-formed UTF-8 sequence (text.size() if
/// none), and the length of the sequence it starts or sits in (0: a byte UTF-8 never starts with).
struct Utf8Error {
  std::size_t bad, start, length;
};
Utf8Error first_utf8_error(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
    const unsigned char b = byte(i);
    // Sequence length and the range of its second byte (RFC 3629, table 3-7 of Unicode).
    std::size_t n = 1;
    unsigned char lo = 0x80, hi = 0xBF;
    if (b < 0x80) {
      n = 1;
    } else if (b >= 0xC2 && b <= 0xDF) {
      n = 2;
    } else if (b >= 0xE0 && b <= 0xEF) {
      n = 3;
      if (b == 0xE0) lo = 0xA0;  // no overlong forms
      if (b == 0xED) hi = 0x9F;  // no surrogates
    } else if (b >= 0xF0 && b <= 0xF4) {
      n = 4;
      if (b == 0xF0) lo = 0x90;  // no overlong forms
      if (b == 0xF4) hi = 0x8F;  // nothing past U+10FFFF
    } else {
      n = 0;  // a continuation byte on its own, or a byte UTF-8 never uses
    }
    std::size_t bad = n == 0 ? i : text.size();  // the offending byte, if any
    for (std::size_t k = 1; bad == text.size() && k < n; ++k) {
      if (i + k == text.size()) {
        bad = i;  // cut off by the end of the text
        break;
      }
      const unsigned char c = byte(i + k);
      if (!(k == 1 ? (c >= lo && c <= hi) : (c >= 0x80 && c <= 0xBF))) bad = i + k;
    }
    if (bad != text.size()) return {bad, i, n};
    i += n;
  }
  return {text.size(), text.size(), 0};
}
}  // namespace

bool is_utf8(std::string_view text) { return first_utf8_error(text).bad == text.size(); }

void require_utf8(std::string_view text, const std::string& source, std::string_view format) {
  const Utf8Error e = first_utf8_error(text);
  if (e.bad == text.size()) return;
  std::size_t line = 1, column = 1;
  for (std::size_t k = 0; k < e.start;) {
    if (text[k] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
    // One column per character: skip the continuation bytes of a (well-formed) sequence.
    ++k;
    while (k < e.start && (static_cast<unsigned char>(text[k]) & 0xC0) == 0x80) ++k;
  }
  static constexpr char kHex[] = "0123456789ABCDEF";
  const auto c = static_cast<unsigned char>(text[e.bad]);
  throw InvalidArgument(source + ": line " + std::to_string(line) + ", column " +
                        std::to_string(column) + ": expected UTF-8 text (as " +
                        std::string(format) + " is), got byte 0x" + kHex[c >> 4] + kHex[c & 0xF] +
                        (e.length == 0      ? ""
                         : e.bad == e.start ? " (a character cut off at the end)"
                                            : " inside a multi-byte character"));
}

YAML::Node load_json(const std::string& json_text, const std::string& source_name) {
  io_detail::require_utf8(json_text, source_name, "JSON");
  // JSON (RFC 8259) has no raw control characters: inside strings they are escaped, outside only
  // tab, line feed and carriage return separate tokens. A raw NUL in a string was read into the
  // metadata, written back as \u0000 and then not read again (found by the fuzzer). yaml-cpp also
  // reads YAML's own escapes and single-quoted strings; its \N and \_ decode to bytes that are
  // not UTF-8 (found by the fuzzer too), so only JSON's escapes and double quotes pass.
  std::size_t line = 1, line_start = 0;
  const auto fail_at = [&](std::size_t i, const std::string& what) {
    std::size_t column = 1;  // characters, not bytes (the text is UTF-8 by now)
    for (std::size_t k = line_start; k < i; ++k)
      column += (static_cast<unsigned char>(json_text[k]) & 0xC0) != 0x80;
    throw InvalidArgument(source_name + ": line " + std::to_string(line) + ", column " +
                          std::to_string(column) + ": " + what);
  };
  bool in_string = false;
  for (std::size_t i = 0; i < json_text.size(); ++i) {
    const char c = json_text[i];
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 && (in_string || (c != '\t' && c != '\n' && c != '\r'))) {
      char code[8];
      std::snprintf(code, sizeof code, "0x%02x", static_cast<unsigned>(u));
      fail_at(i,
              std::string("control character ") + code +
                  (in_string ? " inside a string (JSON writes it as an escape there)"
                             : " (JSON allows control characters only as escapes inside strings)"));
    }
    if (c == '\n') {
      ++line;
      line_start = i + 1;
    }
    if (!in_string) {
      if (c == '"') in_string = true;
      if (c == '\'') fail_at(i, "a single quote (JSON strings are in double quotes)");
      continue;
    }
    if (c == '"') {
      in_string = false;
    } else if (c == '\\') {
      const char e = i + 1 < json_text.size() ? json_text[i + 1] : '\0';
      if (std::string_view("\"\\/bfnrtu").find(e) == std::string_view::npos || e == '\0') {
        fail_at(i, std::string("escape \\") + (e >= 0x20 && e < 0x7f ? std::string(1, e) : "") +
                       " is not JSON (JSON has \\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX)");
      }
      ++i;  // the escaped character
    }
  }
  try {
    return YAML::Load(json_text);
  } catch (const YAML::ParserException& e) {
    throw InvalidArgument(source_name + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                          std::to_string(e.mark.column + 1) + ": JSON syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InvalidArgument(source_name + ": cannot parse JSON: " + e.what());
  }
}

// ---- files ------------------------------------------------------------------------------------

// ---- reader -----------------------------------------------------------------------------------

Reader::Reader(std::string source, NonFinite non_finite)
    : source_(std::move(source)), non_finite_(non_finite) {}

void Reader::fail(const YAML::Node& at, const std::string& path, const std::string& message) const {
  std::string text = source_ + ": ";
  if (!path.empty()) text += path + ": ";
  text += message;
  if (at.IsDefined() && !at.IsNull() && at.Mark().line >= 0)
    text += " (line " + std::to_string(at.Mark().line + 1) + ")";
  throw InvalidArgument(text);
}

void Reader::fail(const std::string& path, const std::string& message) const {
  fail(YAML::Node(YAML::NodeType::Undefined), path, message);
}

namespace {

/// Where the documents of a YAML stream start, and nothing else: the first pass of
/// Reader::parse() counts them with it, building no nodes.
class DocumentStarts : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark& mark) override {
    previous = last;
    last = mark;
    ++count;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

  std::size_t count = 0;
  YAML::Mark previous, last;
};

}  // namespace

YAML::Node Reader::parse(const std::string& yaml_text, const std::string& expected) const {
  require_utf8(yaml_text, source_, "YAML");
  const auto syntax_error = [&](const YAML::Mark& mark, const std::string& message) {
    throw InvalidArgument(source_ + ": line " + std::to_string(mark.line + 1) + ", column " +
                          std::to_string(mark.column + 1) + ": YAML syntax error: " + message);
  };
  // Two passes instead of YAML::LoadAll: yaml-cpp 0.7 never consumes a token no rule takes (a ','
  // or ']' outside a flow collection), and LoadAll then adds empty documents at that token
  // without end, allocating until the machine runs out of memory (found by the fuzzers). The
  // first pass counts documents and stops at one that starts where the previous one did.
  YAML::Node first;
  try {
    std::istringstream in(yaml_text);
    YAML::Parser parser(in);
    DocumentStarts starts;
    YAML::Mark second;
    while (parser.HandleNextDocument(starts)) {
      if (starts.count >= 2 && starts.last.pos == starts.previous.pos) {
        const auto at = static_cast<std::size_t>(starts.last.pos);
        syntax_error(starts.last, at < yaml_text.size()
                                      ? "unexpected '" + yaml_text.substr(at, 1) + "'"
                                      : std::string("unexpected end of the text"));
      }
      if (starts.count == 2) second = starts.last;
      if (starts.count == 3) break;  // enough to tell a second document from a stuck parser
    }
    if (starts.count >= 2) {
      fail("", "expected one YAML document, got 2 or more (the second starts at line " +
                   std::to_string(second.line + 1) + ")");
    }
    if (starts.count == 0) fail("", "empty document; expected " + expected);
    first = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    syntax_error(e.mark, e.msg);
  } catch (const YAML::Exception& e) {
    throw InvalidArgument(source_ + ": cannot parse YAML: " + e.what());
  }
  return first;
}

Map Reader::map(const YAML::Node& node, const std::string& path, NameList allowed,
                const std::string& expected) const {
  if (!node.IsMap()) fail(node, path, "expected " + expected + ", got " + describe(node));
  std::map<std::string, YAML::Node, std::less<>> entries;
  for (const auto& kv : node) {
    if (!kv.first.IsScalar())
      fail(kv.first, path, "expected keys to be names, got " + describe(kv.first));
    const std::string& key = kv.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      fail(kv.first, path,
           "unknown key '" + key + "'" + did_you_mean(key, allowed) +
               " (valid keys: " + name_list(allowed) + ")");
    }
    if (entries.count(key) != 0) fail(kv.first, path, "duplicate key '" + key + "'");
    entries.emplace(key, kv.second);
  }
  return Map(*this, node, path, std::move(entries));
}

double Reader::number(const YAML::Node& node, const std::string& path) const {
  double v = 0.0;
  if (!is_plain(node) || !parse_number(node.Scalar(), v))
    fail(node, path, "expected a number, got " + describe(node));
  if (non_finite_ == NonFinite::kReject && !std::isfinite(v))
    fail(node, path, "expected a finite number, got " + node.Scalar());
  return v;
}

double Reader::positive(const YAML::Node& node, const std::string& path) const {
  const double v = number(node, path);
  if (!(v > 0.0)) fail(node, path, "expected a number > 0, got " + node.Scalar());
  return v;
}

bool Reader::boolean(const YAML::Node& node, const std::string& path) const {
  if (is_plain(node)) {
    const std::string& s = node.Scalar();
    if (s == "true" || s == "True" || s == "TRUE") return true;
    if (s == "false" || s == "False" || s == "FALSE") return false;
  }
  fail(node, path, "expected true or false, got " + describe(node));
}

std::string Reader::string(const YAML::Node& node, const std::string& path) const {
  if (!node.IsScalar() || node.Scalar().empty())
    fail(node, path, "expected a non-empty string, got " + describe(node));
  if (!is_utf8(node.Scalar())) fail(node, path, kNotUtf8AfterEscapes);
  return node.Scalar();
}

std::size_t Reader::choice(const YAML::Node& node, const std::string& path, NameList names,
                           const std::string& what) const {
  if (!node.IsScalar())
    fail(node, path, "expected " + what + " (" + name_list(names) + "), got " + describe(node));
  const std::string& s = node.Scalar();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == s) return i;
  fail(node, path,
       "unknown " + what + " '" + s + "'" + did_you_mean(s, names) +
           " (valid: " + name_list(names) + ")");
}

std::vector<double> Reader::numbers(const YAML::Node& node, const std::string& path,
                                    const std::string& expected) const {
  if (!node.IsSequence()) fail(node, path, "expected " + expected + ", got " + describe(node));
  std::vector<double> out(node.size());
  for (std::size_t i = 0; i < node.size(); ++i) out[i] = number(node[i], item_path(path, i));
  return out;
}

// ---- map --------------------------------------------------------------------------------------

Map::Map(const Reader& reader, YAML::Node node, std::string path,
         std::map<std::string, YAML::Node, std::less<>> entries)
    : reader_(&reader),
      node_(std::move(node)),
      path_(std::move(path)),
      entries_(std::move(entries)) {}

YAML::Node Map::get(std::string_view key) const {
  const auto it = entries_.find(key);
  return it == entries_.end() ? YAML::Node(YAML::NodeType::Undefined) : it->second;
}

YAML::Node Map::required(std::string_view key) const {
  const auto it = entries_.find(key);
  if (it == entries_.end()) {
    // The line of a nested map helps find it; the top level's first line does not.
    const std::string message = "missing required key '" + std::string(key) + "'";
    if (path_.empty()) reader_->fail(path_, message);
    reader_->fail(node_, path_, message);
  }
  return it->second;
}

}  // namespace dronetwin::io_detail
