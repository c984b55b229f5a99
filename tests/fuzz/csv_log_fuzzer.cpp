// libFuzzer harness: CSV logs (logging/csv_log.hpp, read_csv_log through a scratch file, since
// the reader takes a path). For an accepted table: every row is complete, and a table whose
// column names the writer accepts round-trips through CsvLogWriter to the same names and
// numbers (NaN as NaN).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "dronetwin/logging/csv_log.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  static fuzz::ScratchFile input("csv_log_in.csv"), output("csv_log_out.csv");
  LogTable t;
  if (!fuzz::accepted([&] { t = read_csv_log(input.write(data, size)); })) return 0;
  fuzz::check(!t.columns.empty(), "an accepted log has no columns");
  fuzz::check(t.values.size() == t.rows() * t.columns.size(), "an accepted log has a short row");
  if (!fuzz::accepted([&] {
        CsvLogWriter w(output.path(), t.columns);
        for (std::size_t r = 0; r < t.rows(); ++r) {
          w.write_row(t.values.data() + r * t.columns.size(), t.columns.size());
        }
        w.close();
      })) {
    return 0;  // names the writer refuses (a quote, for instance) are fine to read
  }
  LogTable back;
  fuzz::check(fuzz::accepted([&] { back = read_csv_log(output.path()); }),
              "a log written from an accepted table does not read back");
  fuzz::check(back.columns == t.columns, "column names change in a write/read round trip");
  fuzz::check(back.values.size() == t.values.size(), "row count changes in a round trip");
  for (std::size_t i = 0; i < t.values.size(); ++i) {
    const double a = t.values[i], b = back.values[i];
    fuzz::check(a == b || (std::isnan(a) && std::isnan(b)), "a number changes in a round trip");
  }
  return 0;
}
