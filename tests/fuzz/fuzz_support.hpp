#pragma once
// Shared pieces of the libFuzzer harnesses (tests/fuzz/*_fuzzer.cpp, docs/reliability.md,
// "Fuzzing"). A harness feeds one input to a reader; an InvalidArgument is the reader's expected
// answer to a malformed file and is swallowed. Anything else is a finding that libFuzzer reports:
// a crash or sanitizer report, another exception (it reaches std::terminate), a hang (-timeout)
// or memory growth (-rss_limit_mb), and a broken property, which the harness aborts on with
// fuzz::check.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "dronetwin/core/error.hpp"

namespace dronetwin::fuzz {

/// The input as text (any bytes, NULs included).
inline std::string text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs `f`; returns false when it threw InvalidArgument (the input was refused, as it may be).
template <class F>
bool accepted(F&& f) {
  try {
    f();
    return true;
  } catch (const InvalidArgument&) {
    return false;
  }
}

/// Aborts (a finding) with `what` unless `condition` holds: for properties every accepted input
/// must have.
inline void check(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "fuzz property violated: %s\n", what);
    std::abort();
  }
}

/// A file in the temporary directory, one per process and name, for readers that take a path.
/// Removed at exit.
class ScratchFile {
 public:
  explicit ScratchFile(std::string_view name)
      : path_((std::filesystem::temp_directory_path() /
               ("dronetwin_fuzz_" + std::to_string(::getpid()) + "_" + std::string(name)))
                  .string()) {}
  ~ScratchFile() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  /// Replaces the file's content with the bytes; returns its path.
  const std::string& write(const std::uint8_t* data, std::size_t size) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    check(static_cast<bool>(out), "cannot write the scratch file");
    return path_;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace dronetwin::fuzz
