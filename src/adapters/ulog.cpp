// PX4 ULog reader, written from the format description in the PX4 user guide ("ULog File
// Format"): a 16-byte header, then messages of [uint16 size][uint8 type][size bytes], all little
// endian. See include/dronetwin/adapters/ulog.hpp.
#include "dronetwin/adapters/ulog.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

// Caps against hostile files (docs/reliability.md, "Hostile files: bounded memory").
// A message's size field is uint16, so no format can describe more bytes than this.
constexpr std::size_t kMaxMessageBytes = 65535;
// PX4 nests two or three levels; deeper is a corrupt or recursive definition.
constexpr int kMaxNesting = 32;
// Columns (numeric values per message) of all topic instances of a file together, and the
// characters of their names: a real PX4 log has some thousands of columns and well under 1 MiB
// of names. Each topic instance counts as at least one column.
constexpr std::size_t kMaxColumns = std::size_t{1} << 20;
constexpr std::uint64_t kMaxNameBytes = std::uint64_t{64} << 20;
constexpr std::uint64_t kNameCap = kMaxNameBytes + 1;  // "more than the limit", for sums

enum class Basic {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat,
  kDouble,
  kBool,
  kChar
};

std::optional<Basic> basic_type(std::string_view name) {
  static const std::pair<std::string_view, Basic> kTypes[] = {
      {"int8_t", Basic::kInt8},     {"uint8_t", Basic::kUint8},   {"int16_t", Basic::kInt16},
      {"uint16_t", Basic::kUint16}, {"int32_t", Basic::kInt32},   {"uint32_t", Basic::kUint32},
      {"int64_t", Basic::kInt64},   {"uint64_t", Basic::kUint64}, {"float", Basic::kFloat},
      {"double", Basic::kDouble},   {"bool", Basic::kBool},       {"char", Basic::kChar}};
  for (const auto& [n, t] : kTypes) {
    if (n == name) return t;
  }
  return std::nullopt;
}

std::size_t basic_size(Basic t) {
  switch (t) {
    case Basic::kInt8:
    case Basic::kUint8:
    case Basic::kBool:
    case Basic::kChar:
      return 1;
    case Basic::kInt16:
    case Basic::kUint16:
      return 2;
    case Basic::kInt32:
    case Basic::kUint32:
    case Basic::kFloat:
      return 4;
    case Basic::kInt64:
    case Basic::kUint64:
    case Basic::kDouble:
      return 8;
  }
  return 0;
}

template <class T>
T load(const std::uint8_t* p) {
  // The format is little endian; so is every platform we build for (x86-64, aarch64 LE).
  static_assert(std::endian::native == std::endian::little, "ULog reader assumes little endian");
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

double basic_value(Basic t, const std::uint8_t* p) {
  switch (t) {
    case Basic::kInt8:
      return static_cast<double>(load<std::int8_t>(p));
    case Basic::kUint8:
      return static_cast<double>(load<std::uint8_t>(p));
    case Basic::kInt16:
      return static_cast<double>(load<std::int16_t>(p));
    case Basic::kUint16:
      return static_cast<double>(load<std::uint16_t>(p));
    case Basic::kInt32:
      return static_cast<double>(load<std::int32_t>(p));
    case Basic::kUint32:
      return static_cast<double>(load<std::uint32_t>(p));
    case Basic::kInt64:
      return static_cast<double>(load<std::int64_t>(p));
    case Basic::kUint64:
      return static_cast<double>(load<std::uint64_t>(p));
    case Basic::kFloat:
      return static_cast<double>(load<float>(p));
    case Basic::kDouble:
      return load<double>(p);
    case Basic::kBool:
      return p[0] != 0 ? 1.0 : 0.0;
    case Basic::kChar:
      return static_cast<double>(static_cast<unsigned char>(p[0]));
  }
  return 0.0;
}

/// "type[n]" -> ("type", n, array); "type" -> ("type", 1, scalar). n may be 0 (an empty string
/// value `char[0]`). Returns false for malformed array syntax; a count too large for size_t is
/// returned as SIZE_MAX (the callers' size checks then reject it with the number as written).
bool split_array(std::string_view type, std::string_view& base, std::size_t& count,
                 bool& is_array) {
  const std::size_t open = type.find('[');
  is_array = open != std::string_view::npos;
  if (!is_array) {
    base = type;
    count = 1;
    return true;
  }
  if (type.back() != ']' || open == 0) return false;
  base = type.substr(0, open);
  const std::string_view digits = type.substr(open + 1, type.size() - open - 2);
  if (digits.empty()) return false;
  const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), count);
  if (r.ptr != digits.data() + digits.size()) return false;
  if (r.ec == std::errc::result_out_of_range) {
    count = std::numeric_limits<std::size_t>::max();
    return true;
  }
  return r.ec == std::errc{};
}

/// Decimal digits of i.
std::size_t digits(std::size_t i) {
  std::size_t d = 1;
  while (i >= 10) {
    i /= 10;
    ++d;
  }
  return d;
}

/// a + b and a * b, saturating at `cap` (operands are at most `cap`, so nothing overflows first).
std::uint64_t add_capped(std::uint64_t a, std::uint64_t b, std::uint64_t cap) {
  return std::min(a + b, cap);
}
std::uint64_t mul_capped(std::uint64_t a, std::uint64_t b, std::uint64_t cap) {
  return (a != 0 && b > cap / a) ? cap : std::min(a * b, cap);
}

struct Field {
  std::string type_name;  // base type: a basic type or a nested format name
  std::size_t count = 1;  // number of elements (1 for a scalar)
  bool is_array = false;
  std::string name;
  std::string declaration;  // "type name" as written, for messages

  bool padding() const { return name.rfind("_padding", 0) == 0; }
  /// char[n] is a string: not a column.
  bool text(std::optional<Basic> basic) const { return basic == Basic::kChar && is_array; }
};

/// What a format flattens to, computed (and cached) at its first subscription.
struct FormatInfo {
  std::size_t size = 0;          // bytes, at most kMaxMessageBytes
  std::size_t leaves = 0;        // numeric values (columns); at most size
  std::uint64_t name_bytes = 0;  // characters of all column names, capped at kMaxNameBytes + 1
};

/// One numeric value inside a data message.
struct Leaf {
  std::size_t offset;
  Basic type;
};

/// A format flattened to its columns, built at the first data message that needs it.
struct Layout {
  std::vector<Leaf> leaves;  // non-padding, non-text values
  std::vector<std::string> names;
  std::size_t min_size = 0;  // bytes needed for every leaf (trailing padding may be absent)
  std::optional<std::size_t> timestamp_leaf;
};

struct Format {
  std::vector<Field> fields;
  std::size_t definition_offset = 0;
  std::optional<FormatInfo> info;
  bool visiting = false;  // on the stack of format_info (a format that contains itself)
  std::optional<Layout> layout;
};

struct Subscription {
  std::string name;
  int multi_id = 0;
  Format* format = nullptr;  // a node of Parser::formats_ (std::map nodes do not move)
  std::optional<std::size_t> topic_index;  // set at its first data message
};

class Parser {
 public:
  Parser(const std::vector<std::uint8_t>& bytes, const std::string& source)
      : b_(bytes), source_(source) {}

  ULog run();

 private:
  template <class... Parts>
  [[noreturn]] void fail(std::size_t offset, const Parts&... parts) const {
    throw InvalidArgument(detail::concat(source_, ": byte ", offset, ": ", parts...));
  }

  const FormatInfo& format_info(const std::string& name, Format& format, std::size_t at, int depth);
  void flatten(const Format& format, const std::string& prefix, std::size_t base, Layout& out);
  std::string decode_value(std::string_view type, const std::uint8_t* p, std::size_t n,
                           std::size_t at, double* number);
  void parse_format(const std::uint8_t* p, std::size_t n, std::size_t at);
  void parse_key_value(const std::uint8_t* p, std::size_t n, std::size_t at, char kind);
  void parse_subscription(const std::uint8_t* p, std::size_t n, std::size_t at);
  std::size_t first_data(Subscription& s, std::size_t at);
  void parse_data(const std::uint8_t* p, std::size_t n, std::size_t at);

  const std::vector<std::uint8_t>& b_;
  const std::string& source_;
  ULog log_;
  std::map<std::string, Format> formats_;
  std::map<std::uint16_t, Subscription> subscriptions_;
  std::map<std::pair<std::string, int>, std::size_t> topic_index_;
  std::size_t columns_ = 0;       // columns of every topic so far (capped at kMaxColumns)
  std::uint64_t name_bytes_ = 0;  // characters of their names (capped at kMaxNameBytes)
  bool data_section_ = false;
  std::size_t appended_offset_ = 0;  // 0: no appended data
};

/// Size, column count and column-name length of a format, checked against the message limit
/// field by field with overflow-safe arithmetic; `at` is the offset of the message that uses it.
const FormatInfo& Parser::format_info(const std::string& name, Format& format, std::size_t at,
                                      int depth) {
  if (format.info) return *format.info;
  if (format.visiting) {
    fail(at, "format '", name, "' contains itself (a recursive format has no finite size)");
  }
  if (depth >= kMaxNesting) {
    fail(at, "format '", name, "': message formats nest deeper than ", kMaxNesting, " levels");
  }
  format.visiting = true;
  FormatInfo info;
  for (const Field& field : format.fields) {
    const auto basic = basic_type(field.type_name);
    FormatInfo elem;
    if (basic) {
      elem = {basic_size(*basic), 1, 0};
    } else {
      const auto nested = formats_.find(field.type_name);
      if (nested == formats_.end()) {
        fail(at, "format '", name, "', field '", field.declaration, "': unknown type '",
             field.type_name, "' (no format 'F' message defines it)");
      }
      elem = format_info(nested->first, nested->second, at, depth + 1);
    }
    // count * elem.size <= kMaxMessageBytes - info.size, without computing the product first.
    if (elem.size != 0 && field.count > (kMaxMessageBytes - info.size) / elem.size) {
      fail(at, "format '", name, "', field '", field.declaration, "': ", field.count, " x ",
           elem.size, " bytes make the format larger than ", kMaxMessageBytes,
           " bytes, the limit of a ULog message (format defined at byte ", format.definition_offset,
           ")");
    }
    info.size += field.count * elem.size;
    if (field.padding() || field.text(basic) || elem.leaves == 0) continue;
    // Every leaf of every element, named prefix + the element's own column name, where the prefix
    // is `name`, `name[i]`, `name.` or `name[i].`; elem.leaves >= 1 implies elem.size >= 1, so
    // count <= kMaxMessageBytes here and the loop is short.
    const std::uint64_t dot = basic ? 0 : 1;
    std::uint64_t prefixes = mul_capped(field.count, field.name.size() + dot, kNameCap);
    if (field.is_array) {
      for (std::size_t i = 0; i < field.count; ++i) prefixes += 2 + digits(i);
      prefixes = std::min(prefixes, kNameCap);
    }
    info.leaves += field.count * elem.leaves;  // <= info.size <= kMaxMessageBytes
    info.name_bytes =
        add_capped(info.name_bytes, mul_capped(prefixes, elem.leaves, kNameCap), kNameCap);
    info.name_bytes =
        add_capped(info.name_bytes, mul_capped(field.count, elem.name_bytes, kNameCap), kNameCap);
  }
  format.visiting = false;
  format.info = info;
  return *format.info;
}

void Parser::flatten(const Format& format, const std::string& prefix, std::size_t base,
                     Layout& out) {
  std::size_t offset = base;
  for (const Field& field : format.fields) {
    const auto basic = basic_type(field.type_name);
    // format_info() has checked every nested format and cached its numbers.
    const Format* nested = basic ? nullptr : &formats_.find(field.type_name)->second;
    const std::size_t elem = basic ? basic_size(*basic) : nested->info->size;
    const std::size_t elem_leaves = basic ? 1 : nested->info->leaves;
    if (!field.padding() && !field.text(basic) && elem_leaves != 0) {
      for (std::size_t i = 0; i < field.count; ++i) {
        std::string name = prefix + field.name;
        if (field.is_array) name += "[" + std::to_string(i) + "]";
        const std::size_t o = offset + i * elem;
        if (basic) {
          out.leaves.push_back({o, *basic});
          out.names.push_back(std::move(name));
        } else {
          flatten(*nested, name + ".", o, out);
        }
      }
    }
    offset += elem * field.count;
  }
}

std::string Parser::decode_value(std::string_view type, const std::uint8_t* p, std::size_t n,
                                 std::size_t at, double* number) {
  std::string_view base;
  std::size_t count = 1;
  bool is_array = false;
  if (!split_array(type, base, count, is_array)) fail(at, "malformed type '", type, "'");
  const auto t = basic_type(base);
  if (!t) fail(at, "value type '", type, "' is not a basic type");
  const std::size_t elem = basic_size(*t);
  // n == count * elem, without computing a product that may overflow.
  if (count > n / elem || count * elem != n) {
    fail(at, "value of type ", type, " has ", n, " bytes, expected ", count, " x ", elem);
  }
  if (*t == Basic::kChar && is_array) return std::string(reinterpret_cast<const char*>(p), n);
  std::ostringstream out;
  out.precision(17);
  for (std::size_t i = 0; i < count; ++i) {
    const double v = basic_value(*t, p + i * elem);
    if (i == 0 && number) *number = v;
    if (i > 0) out << ' ';
    if (*t == Basic::kInt64) {
      out << load<std::int64_t>(p + i * 8);
    } else if (*t == Basic::kUint64) {
      out << load<std::uint64_t>(p + i * 8);
    } else {
      out << v;
    }
  }
  return out.str();
}

void Parser::parse_format(const std::uint8_t* p, std::size_t n, std::size_t at) {
  const std::string_view text(reinterpret_cast<const char*>(p), n);
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0) {
    fail(at, "format message without 'name:' prefix: '", text.substr(0, 60), "'");
  }
  const std::string name(text.substr(0, colon));
  Format f;
  f.definition_offset = at;
  std::size_t start = colon + 1;
  std::size_t basic_bytes = 0;  // the fields of basic types so far
  while (start < text.size()) {
    std::size_t semi = text.find(';', start);
    if (semi == std::string_view::npos) semi = text.size();
    const std::string_view item = text.substr(start, semi - start);
    start = semi + 1;
    if (item.empty()) continue;
    const std::size_t space = item.find(' ');
    if (space == std::string_view::npos || space == 0 || space + 1 >= item.size()) {
      fail(at, "format '", name, "': field '", item, "' is not 'type name'");
    }
    Field field;
    std::string_view base;
    if (!split_array(item.substr(0, space), base, field.count, field.is_array)) {
      fail(at, "format '", name, "': malformed array type in '", item, "'");
    }
    field.type_name = std::string(base);
    field.name = std::string(item.substr(space + 1));
    field.declaration = std::string(item);
    // Reject what cannot fit in a message here, where the file says it; nested formats may be
    // defined later and are checked when the format is subscribed (format_info).
    if (field.count > kMaxMessageBytes) {
      fail(at, "format '", name, "', field '", item, "': ", field.count,
           " elements exceed the limit of a ULog message (", kMaxMessageBytes, " bytes)");
    }
    if (const auto t = basic_type(field.type_name)) {
      basic_bytes += field.count * basic_size(*t);  // <= 65535 * 8 + previous <= 65535
      if (basic_bytes > kMaxMessageBytes) {
        fail(at, "format '", name, "', field '", item, "': the fields so far take ", basic_bytes,
             " bytes, more than ", kMaxMessageBytes, ", the limit of a ULog message");
      }
    }
    f.fields.push_back(std::move(field));
  }
  if (f.fields.empty()) fail(at, "format '", name, "' has no fields");
  if (formats_.count(name)) fail(at, "format '", name, "' defined twice");
  formats_.emplace(name, std::move(f));
}

void Parser::parse_key_value(const std::uint8_t* p, std::size_t n, std::size_t at, char kind) {
  // 'I'/'P': [key_len][key][value]; 'M': [is_continued][key_len]...; 'Q':
  // [default_types][key_len]...
  std::size_t skip = (kind == 'M' || kind == 'Q') ? 1 : 0;
  if (n < skip + 1) fail(at, "'", kind, "' message too short (", n, " bytes)");
  const std::size_t key_len = p[skip];
  if (skip + 1 + key_len > n) {
    fail(at, "'", kind, "' message key length ", key_len, " exceeds the message (", n, " bytes)");
  }
  const std::string_view key(reinterpret_cast<const char*>(p + skip + 1), key_len);
  const std::size_t space = key.find(' ');
  if (space == std::string_view::npos) fail(at, "'", kind, "' key '", key, "' is not 'type name'");
  const std::string_view type = key.substr(0, space);
  const std::string name(key.substr(space + 1));
  const std::uint8_t* value = p + skip + 1 + key_len;
  const std::size_t value_len = n - skip - 1 - key_len;
  double number = 0.0;
  std::string text = decode_value(type, value, value_len, at, &number);
  switch (kind) {
    case 'I':
      log_.info[name] = std::move(text);
      break;
    case 'M': {
      auto& list = log_.info_multiple[name];
      if (p[0] != 0 && !list.empty()) {
        list.back() += text;  // continued value
      } else {
        list.push_back(std::move(text));
      }
      break;
    }
    case 'P':
      if (type != "float" && type != "int32_t") {
        fail(at, "parameter '", name, "' has type ", type, ", expected float or int32_t");
      }
      if (data_section_) log_.parameter_changes.emplace_back(name, number);
      log_.parameters[name] = number;
      break;
    default:
      break;  // 'Q' default values: read and checked, not kept
  }
}

void Parser::parse_subscription(const std::uint8_t* p, std::size_t n, std::size_t at) {
  if (n < 4) fail(at, "subscription 'A' message too short (", n, " bytes, expected >= 4)");
  const int multi_id = p[0];
  const auto msg_id = load<std::uint16_t>(p + 1);
  std::string name(reinterpret_cast<const char*>(p + 3), n - 3);
  const auto f = formats_.find(name);
  if (f == formats_.end()) fail(at, "subscription to '", name, "' which has no format");
  if (subscriptions_.count(msg_id)) fail(at, "msg_id ", msg_id, " subscribed twice");
  // Sizes, nesting and column counts are checked here; the columns themselves are built at the
  // first data message, so that a subscription costs no memory beyond its own few bytes.
  (void)format_info(f->first, f->second, at, 0);
  subscriptions_.emplace(msg_id, Subscription{std::move(name), multi_id, &f->second, {}});
}

/// The topic of a subscription at its first data message: the format's layout (built once per
/// format) and the topic instance (once per name and multi_id), within the reader's caps.
std::size_t Parser::first_data(Subscription& s, std::size_t at) {
  const auto key = std::make_pair(s.name, s.multi_id);
  if (const auto it = topic_index_.find(key); it != topic_index_.end()) return it->second;
  const FormatInfo& info = *s.format->info;
  const std::size_t columns = std::max<std::size_t>(info.leaves, 1);
  if (columns > kMaxColumns - columns_) {
    fail(at, "topic '", s.name, "' (multi_id ", s.multi_id, ") adds ", columns, " columns to the ",
         columns_, " of the topics before it, more than the reader's limit of ", kMaxColumns,
         " columns in a file");
  }
  if (info.name_bytes > kMaxNameBytes - name_bytes_) {
    fail(at, "topic '", s.name, "' (multi_id ", s.multi_id, "): its column names take ",
         info.name_bytes >= kNameCap ? "more than " : "", std::min(info.name_bytes, kMaxNameBytes),
         " bytes, which with the ", name_bytes_,
         " bytes of the topics before it exceeds the reader's limit of ", kMaxNameBytes,
         " bytes of column names in a file");
  }
  columns_ += columns;
  name_bytes_ += info.name_bytes;
  if (!s.format->layout) {
    Layout layout;
    layout.leaves.reserve(info.leaves);
    layout.names.reserve(info.leaves);
    flatten(*s.format, "", 0, layout);
    for (std::size_t i = 0; i < layout.leaves.size(); ++i) {
      const Leaf& leaf = layout.leaves[i];
      layout.min_size = std::max(layout.min_size, leaf.offset + basic_size(leaf.type));
      if (layout.names[i] == "timestamp" && leaf.type == Basic::kUint64) layout.timestamp_leaf = i;
    }
    s.format->layout = std::move(layout);
  }
  const std::size_t index = log_.topics.size();
  ULogTopic t;
  t.name = s.name;
  t.multi_id = s.multi_id;
  t.columns = s.format->layout->names;
  t.values.assign(t.columns.size(), {});
  log_.topics.push_back(std::move(t));
  topic_index_.emplace(key, index);
  return index;
}

void Parser::parse_data(const std::uint8_t* p, std::size_t n, std::size_t at) {
  if (n < 2) fail(at, "data 'D' message too short (", n, " bytes)");
  const auto msg_id = load<std::uint16_t>(p);
  const auto it = subscriptions_.find(msg_id);
  if (it == subscriptions_.end()) {
    fail(at, "data message for msg_id ", msg_id, ", which no 'A' message subscribed");
  }
  Subscription& s = it->second;
  const std::uint8_t* d = p + 2;
  const std::size_t size = n - 2;
  const FormatInfo& info = *s.format->info;
  if (size > info.size) {
    fail(at, "data message of '", s.name, "' has ", size, " bytes, expected at most ", info.size);
  }
  if (!s.topic_index) s.topic_index = first_data(s, at);
  const Layout& layout = *s.format->layout;
  if (size < layout.min_size) {
    fail(at, "data message of '", s.name, "' has ", size, " bytes, expected ", layout.min_size,
         "..", info.size);
  }
  ULogTopic& topic = log_.topics[*s.topic_index];
  for (std::size_t i = 0; i < layout.leaves.size(); ++i) {
    const Leaf& leaf = layout.leaves[i];
    double v = basic_value(leaf.type, d + leaf.offset);
    if (i == layout.timestamp_leaf) {
      const auto us = load<std::uint64_t>(d + leaf.offset);
      topic.timestamp_us.push_back(us);
      v = static_cast<double>(us) * 1e-6;
    }
    topic.values[i].push_back(v);
  }
}

ULog Parser::run() {
  static constexpr std::uint8_t kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
  log_.source = source_;
  if (b_.size() < 16) fail(0, "file too short for a ULog header (", b_.size(), " bytes, need 16)");
  if (std::memcmp(b_.data(), kMagic, 7) != 0) {
    fail(0, "not a ULog file (bad magic; expected 'ULog' 01 12 35)");
  }
  log_.version = b_[7];
  log_.start_timestamp_us = load<std::uint64_t>(b_.data() + 8);
  std::size_t pos = 16;
  bool first = true;
  while (pos < b_.size()) {
    // Appended data (flag bits): the main stream may stop in the middle of a message; whatever
    // crosses the appended offset is cut off and reading resumes there.
    if (appended_offset_ > pos &&
        (appended_offset_ - pos < 3 ||
         pos + 3 + load<std::uint16_t>(b_.data() + pos) > appended_offset_)) {
      pos = appended_offset_;
      continue;
    }
    if (b_.size() - pos < 3) {
      fail(pos, "truncated message header (", b_.size() - pos, " bytes left, need 3)");
    }
    const std::size_t size = load<std::uint16_t>(b_.data() + pos);
    const char type = static_cast<char>(b_[pos + 2]);
    const std::size_t at = pos;
    if (b_.size() - pos - 3 < size) {
      fail(at, "truncated '", type, "' message: declares ", size, " bytes, only ",
           b_.size() - pos - 3, " left in the file");
    }
    const std::uint8_t* p = b_.data() + pos + 3;
    pos += 3 + size;
    switch (type) {
      case 'B': {
        if (!first) fail(at, "flag bits 'B' message must directly follow the header");
        if (size < 40) fail(at, "flag bits message has ", size, " bytes, expected 40");
        // incompat_flags[0] bit 0 = appended data; any other incompatible bit is unknown to us.
        if ((p[8] & ~1u) != 0) fail(at, "unknown incompatible flag bits in byte 0: ", int(p[8]));
        for (int i = 1; i < 8; ++i) {
          if (p[8 + i] != 0) fail(at, "unknown incompatible flag bits in byte ", i);
        }
        if (p[8] & 1u) {
          const auto off = load<std::uint64_t>(p + 16);
          if (off != 0 && (off < pos || off > b_.size())) {
            fail(at, "appended-data offset ", off, " outside the file (", pos, "..", b_.size(),
                 ")");
          }
          appended_offset_ = static_cast<std::size_t>(off);
        }
        break;
      }
      case 'F':
        parse_format(p, size, at);
        break;
      case 'I':
      case 'M':
      case 'P':
      case 'Q':
        parse_key_value(p, size, at, type);
        break;
      case 'A':
        data_section_ = true;
        parse_subscription(p, size, at);
        break;
      case 'R': {
        if (size < 2) fail(at, "remove 'R' message too short");
        subscriptions_.erase(load<std::uint16_t>(p));
        break;
      }
      case 'D':
        data_section_ = true;
        parse_data(p, size, at);
        break;
      case 'L':
      case 'C': {
        const std::size_t head = type == 'L' ? 9 : 11;
        if (size < head) fail(at, "logging '", type, "' message too short (", size, " bytes)");
        ULogMessage m;
        const char lvl = static_cast<char>(p[0]);
        m.level = (lvl >= '0' && lvl <= '7') ? lvl - '0' : static_cast<int>(p[0]);
        if (type == 'C') m.tag = load<std::uint16_t>(p + 1);
        m.timestamp_us = load<std::uint64_t>(p + head - 8);
        m.text.assign(reinterpret_cast<const char*>(p + head), size - head);
        log_.messages.push_back(std::move(m));
        break;
      }
      case 'S': {
        static constexpr std::uint8_t kSync[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
        if (size != 8 || std::memcmp(p, kSync, 8) != 0) fail(at, "bad sync 'S' message");
        break;
      }
      case 'O': {
        if (size < 2) fail(at, "dropout 'O' message too short");
        log_.dropout_total_ms += load<std::uint16_t>(p);
        ++log_.dropout_count;
        break;
      }
      default:
        // The format allows new message types (readers skip them), but a byte that is not an
        // upper-case letter is corruption, not a newer writer.
        if (type < 'A' || type > 'Z') {
          fail(at, "invalid message type byte 0x", std::hex, int(b_[at + 2]), std::dec,
               " (corrupt file?)");
        }
        break;
    }
    first = false;
  }
  // Topics ordered by (name, multi_id) for a stable listing.
  std::sort(log_.topics.begin(), log_.topics.end(), [](const ULogTopic& a, const ULogTopic& b) {
    return std::tie(a.name, a.multi_id) < std::tie(b.name, b.multi_id);
  });
  std::erase_if(log_.topics, [](const ULogTopic& t) { return t.num_messages() == 0; });
  return std::move(log_);
}

}  // namespace

bool ULogTopic::has_column(std::string_view c) const {
  return std::find(columns.begin(), columns.end(), c) != columns.end();
}

const std::vector<double>& ULogTopic::column(std::string_view c) const {
  const auto it = std::find(columns.begin(), columns.end(), c);
  if (it == columns.end()) {
    std::string all;
    for (const auto& s : columns) all += (all.empty() ? "" : ", ") + s;
    throw InvalidArgument(detail::concat("ULog topic '", name, "' (multi_id ", multi_id,
                                         "): no field '", c, "' (fields: ", all, ")"));
  }
  return values[static_cast<std::size_t>(it - columns.begin())];
}

bool ULog::has_topic(std::string_view name, int multi_id) const {
  return std::any_of(topics.begin(), topics.end(),
                     [&](const ULogTopic& t) { return t.name == name && t.multi_id == multi_id; });
}

const ULogTopic& ULog::topic(std::string_view name, int multi_id) const {
  for (const ULogTopic& t : topics) {
    if (t.name == name && t.multi_id == multi_id) return t;
  }
  std::string all;
  for (const ULogTopic& t : topics) {
    all += (all.empty() ? "" : ", ") + t.name + "/" + std::to_string(t.multi_id);
  }
  throw InvalidArgument(detail::concat(source, ": no logged topic '", name, "' with multi_id ",
                                       multi_id, " (logged: ", all, ")"));
}

ULog parse_ulog(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  return Parser(bytes, source).run();
}

ULog read_ulog(const std::string& path) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), path, ": cannot open ULog file (", errno_text(), ")");
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  require(!in.bad(), path, ": error while reading the file");
  return parse_ulog(bytes, path);
}

}  // namespace dronetwin
