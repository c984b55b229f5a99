// CSV run logs (format in include/dronetwin/io/csv_log.hpp and docs/experiment-format.md).
#include "dronetwin/io/csv_log.hpp"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/wrench.hpp"

namespace dronetwin {

namespace {
constexpr std::size_t kBufferBytes = 1 << 16;
// "%.17g" of a double is at most 24 characters ("-1.2345678901234567e-308"); one field never
// needs more than this, separator included.
constexpr std::size_t kMaxFieldBytes = 32;

std::string errno_text() {
  return errno != 0 ? std::generic_category().message(errno) : std::string("unknown error");
}
}  // namespace

std::vector<std::string> log_column_names(const LogLayout& layout) {
  static constexpr const char* kState[] = {"x",  "y",  "z",  "vx", "vy", "vz", "qw",
                                           "qx", "qy", "qz", "wx", "wy", "wz"};
  std::vector<std::string> c;
  c.emplace_back("t");
  for (const char* s : kState) c.emplace_back(s);
  for (int i = 0; i < layout.num_rotors; ++i) c.push_back("omega_" + std::to_string(i));
  for (int i = 0; i < layout.num_rotors; ++i) c.push_back("omega_ref_" + std::to_string(i));
  if (layout.measured)
    for (const char* s : kState) c.push_back(std::string("meas_") + s);
  c.emplace_back("in_contact");
  c.emplace_back("crashed");
  if (layout.wrench_breakdown) {
    for (int k = 0; k < kNumTerms; ++k) {
      const std::string term(term_name(static_cast<Term>(k)));
      for (const char* kind : {"F_", "M_"})
        for (const char* axis : {"_x", "_y", "_z"}) c.push_back(kind + term + axis);
    }
  }
  if (layout.controller) {
    for (const char* s : {"ref_x", "ref_y", "ref_z", "ref_yaw", "u_T", "u_tau_x", "u_tau_y",
                          "u_tau_z", "saturated"})
      c.emplace_back(s);
    for (const std::string& d : layout.controller_diagnostics) c.push_back("ctrl_" + d);
  }
  return c;
}

// ---- writer -----------------------------------------------------------------------------------

CsvLogWriter::CsvLogWriter(const std::string& path, std::vector<std::string> columns)
    : path_(path), columns_(std::move(columns)), buffer_(kBufferBytes) {
  require(!columns_.empty(), path_, ": a log needs at least one column");
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    const std::string& name = columns_[i];
    require(!name.empty() && name.find_first_of(",\"\r\n") == std::string::npos, path_, ": column ",
            i, ": expected a name without commas, quotes or line breaks, got '", name, "'");
  }
  errno = 0;
  file_ = std::fopen(path_.c_str(), "wb");
  require(file_ != nullptr, path_, ": cannot open for writing (", errno_text(), ")");
  std::string header;
  for (std::size_t i = 0; i < columns_.size(); ++i) header += (i ? "," : "") + columns_[i];
  header += '\n';
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) write_error_ = true;
}

CsvLogWriter::~CsvLogWriter() {
  if (file_ == nullptr) return;
  write_buffer();
  std::fclose(file_);
}

void CsvLogWriter::write_buffer() {
  if (used_ > 0 && std::fwrite(buffer_.data(), 1, used_, file_) != used_) write_error_ = true;
  used_ = 0;
}

void CsvLogWriter::write_row(const double* values, std::size_t n) {
  require(file_ != nullptr, path_, ": write_row after close()");
  require(n == columns_.size(), path_, ": row ", rows_ + 1, ": expected ", columns_.size(),
          " values (one per column), got ", n);
  for (std::size_t i = 0; i < n; ++i) {
    if (buffer_.size() - used_ < kMaxFieldBytes) write_buffer();
    // to_chars with precision 17 in general format is specified to print exactly what
    // printf("%.17g") prints in the C locale; it is ~3x faster and ignores the global locale.
    char* const first = buffer_.data() + used_;
    const auto r =
        std::to_chars(first, first + kMaxFieldBytes - 1, values[i], std::chars_format::general, 17);
    used_ += static_cast<std::size_t>(r.ptr - first);
    buffer_[used_++] = i + 1 < n ? ',' : '\n';
  }
  ++rows_;
}

void CsvLogWriter::flush() {
  if (file_ == nullptr) return;
  write_buffer();
  if (std::fflush(file_) != 0) write_error_ = true;
}

void CsvLogWriter::close() {
  if (file_ == nullptr) return;
  write_buffer();
  const bool close_failed = std::fclose(file_) != 0;
  file_ = nullptr;
  require(!write_error_ && !close_failed, path_, ": error while writing the log");
}

// ---- reader -----------------------------------------------------------------------------------

std::size_t LogTable::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  throw InvalidArgument((source.empty() ? std::string("log") : source) + ": no column '" +
                        std::string(name) + "'");
}

std::vector<double> LogTable::column_values(std::string_view name) const {
  const std::size_t c = column(name);
  std::vector<double> out(rows());
  for (std::size_t r = 0; r < out.size(); ++r) out[r] = at(r, c);
  return out;
}

LogTable read_csv_log(const std::string& path) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), path, ": cannot open log (", errno_text(), ")");
  LogTable t;
  t.source = path;
  std::string line;
  std::size_t line_number = 0;
  const auto strip_cr = [](std::string& s) {
    if (!s.empty() && s.back() == '\r') s.pop_back();
  };
  require(static_cast<bool>(std::getline(in, line)), path,
          ": line 1: empty file, expected a header");
  ++line_number;
  strip_cr(line);
  {
    std::size_t start = 0;
    for (;;) {
      const std::size_t comma = line.find(',', start);
      std::string name =
          line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      require(!name.empty(), path, ": line 1, column ", t.columns.size() + 1,
              ": expected a column name, got an empty field");
      t.columns.push_back(std::move(name));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  const std::size_t n = t.columns.size();
  while (std::getline(in, line)) {
    ++line_number;
    strip_cr(line);
    if (line.empty() && in.peek() == std::char_traits<char>::eof()) break;  // trailing newline
    const char* p = line.data();
    const char* const end = p + line.size();
    std::size_t col = 0;
    for (;;) {
      const char* comma =
          static_cast<const char*>(std::memchr(p, ',', static_cast<std::size_t>(end - p)));
      const char* field_end = comma ? comma : end;
      require(col < n, path, ": line ", line_number, ": expected ", n, " fields, got more");
      double v = 0.0;
      const auto r = std::from_chars(p, field_end, v);
      if (r.ec != std::errc{} || r.ptr != field_end || p == field_end) {
        require(false, path, ": line ", line_number, ", column ", col + 1, " (", t.columns[col],
                "): expected a number, got '", std::string(p, field_end), "'");
      }
      t.values.push_back(v);
      ++col;
      if (!comma) break;
      p = comma + 1;
    }
    require(col == n, path, ": line ", line_number, ": expected ", n, " fields, got ", col);
  }
  require(!in.bad(), path, ": error while reading the log");
  return t;
}

}  // namespace dronetwin
