// Hostile PX4 ULog files, crafted byte by byte: formats that declare more bytes than a ULog
// message can hold (a huge array, nested arrays whose sizes multiply past 2^64), formats that
// contain themselves or name unknown types, and files whose columns or column names would take
// gigabytes. Each is refused with an InvalidArgument naming the byte offset, the format and the
// field, before anything is allocated for it (docs/reliability.md, "Hostile files: bounded
// memory"). Every hostile file is parsed in a child process that may map at most 1 GiB
// (RLIMIT_AS), so that running out of memory is a test failure and a regression cannot eat the
// machine (before the caps, the huge array asked for more than 12 GB).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include "adapters/ulog_bytes.hpp"
#include "dronetwin/adapters/ulog.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

using test::Bytes;
using test::format;
using test::message;
using test::subscribe;
using test::ulog_header;

/// A data 'D' message for msg_id with `payload_bytes` bytes of value `fill`.
void data(Bytes& f, std::uint16_t msg_id, std::size_t payload_bytes, std::uint8_t fill = 0) {
  Bytes p;
  p.put(msg_id);
  for (std::size_t i = 0; i < payload_bytes; ++i) p.put(fill);
  message(f, 'D', p);
}

/// "<file>: byte <at>", the start of the reader's messages (built with += : GCC 12 warns falsely
/// (-Wrestrict) about "literal" + std::string).
std::string where(const std::string& file, std::size_t at) {
  std::string s = file;
  s += ": byte ";
  s += std::to_string(at);
  return s;
}

/// How parse_ulog answered a file: 'E' InvalidArgument, 'A' accepted, 'M' out of memory, 'X'
/// another exception, 'S' the process died; `text` is the message.
struct Outcome {
  char kind = 'S';
  std::string text;
};

Outcome parse_in_process(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  try {
    (void)parse_ulog(bytes, source);
    return {'A', ""};
  } catch (const InvalidArgument& e) {
    return {'E', e.what()};
  } catch (const std::bad_alloc&) {
    return {'M', "std::bad_alloc"};
  } catch (const std::exception& e) {
    return {'X', e.what()};
  }
}

/// parse_in_process in a child process limited to 1 GiB of address space. ASan reserves
/// terabytes of address space for its shadow memory, so the sanitizer build parses in process.
Outcome parse_bounded(const std::vector<std::uint8_t>& bytes, const std::string& source) {
#if defined(__SANITIZE_ADDRESS__)
  return parse_in_process(bytes, source);
#else
  int fds[2];
  if (::pipe(fds) != 0) return {'S', "pipe failed"};
  const pid_t child = ::fork();
  if (child < 0) return {'S', "fork failed"};
  if (child == 0) {
    ::close(fds[0]);
    const rlimit limit{rlim_t{1} << 30, rlim_t{1} << 30};
    Outcome o{'S', "setrlimit failed"};
    if (::setrlimit(RLIMIT_AS, &limit) == 0) o = parse_in_process(bytes, source);
    const std::string reply = o.kind + o.text;
    for (std::size_t done = 0; done < reply.size();) {
      const ssize_t n = ::write(fds[1], reply.data() + done, reply.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string reply;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n > 0) {
      reply.append(buffer, static_cast<std::size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  ::close(fds[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  if (!WIFEXITED(status) || reply.empty()) {
    return {'S', "the child died (signal " + std::to_string(WTERMSIG(status)) + ")"};
  }
  return {reply[0], reply.substr(1)};
#endif
}

/// The InvalidArgument message for a hostile file (a test failure if it got another answer).
std::string refusal(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  const Outcome o = parse_bounded(bytes, source);
  EXPECT_EQ(o.kind, 'E') << "expected InvalidArgument ('E'), got '" << o.kind << "': " << o.text;
  return o.text;
}

void expect_contains(const std::string& error, const std::vector<std::string>& parts) {
  for (const std::string& part : parts) EXPECT_NE(error.find(part), std::string::npos) << error;
}

// The file: ~100 bytes that made the reader allocate 2e9 columns (> 12 GB).
std::vector<std::uint8_t> huge_array_file() {
  Bytes f = ulog_header();
  format(f, "huge:uint64_t timestamp;float[2000000000] x");  // at byte 16
  subscribe(f, "huge", 0);
  data(f, 0, 8 + 4);
  return f.bytes();
}

// Sizes 2^15, 2^30, 2^45, 2^60 and 16 * 2^60 = 2^64, which wraps to 0 in 64-bit arithmetic.
std::vector<std::uint8_t> nested_overflow_file(std::size_t* subscription_at) {
  Bytes f = ulog_header();
  format(f, "d:uint8_t[32768] x");
  format(f, "c:d[32768] d");
  format(f, "b:c[32768] c");
  format(f, "a:b[32768] b");
  format(f, "z:a[16] a");
  *subscription_at = f.size();
  subscribe(f, "z", 0);
  data(f, 0, 1);
  return f.bytes();
}

// One column of 60000 values with a 65000-character name: 60000 names of 65000 characters
// (3.9 GB), from a file of 125 kB.
std::vector<std::uint8_t> long_names_file(std::size_t* data_at) {
  Bytes f = ulog_header();
  format(f, "in:uint8_t[60000] x");
  std::string out = "out:in ";
  out.append(65000, 'n');
  format(f, out);
  subscribe(f, "out", 3, 2);
  *data_at = f.size();
  data(f, 3, 60000);
  return f.bytes();
}

TEST(ULogHostile, HugeArrayIsRefusedAtItsFormatMessage) {
  const std::string e = refusal(huge_array_file(), "huge.ulg");
  expect_contains(e, {"huge.ulg: byte 16: format 'huge', field 'float[2000000000] x'",
                      "2000000000 elements", "65535 bytes"});
  // A count that does not even fit in 64 bits.
  Bytes f = ulog_header();
  format(f, "h:float[99999999999999999999999] x");
  expect_contains(refusal(f.bytes(), "h.ulg"),
                  {"h.ulg: byte 16: format 'h', field 'float[99999999999999999999999] x'"});
}

TEST(ULogHostile, FieldsTogetherLargerThanAMessageAreRefused) {
  Bytes f = ulog_header();
  format(f, "two:double[4096] a;double[4096] b");  // 32768 + 32768 = 65536 bytes
  expect_contains(
      refusal(f.bytes(), "two.ulg"),
      {"two.ulg: byte 16: format 'two', field 'double[4096] b'", "65536 bytes", "more than 65535"});
}

TEST(ULogHostile, NestedSizesThatWouldOverflowAreRefusedAtTheSubscription) {
  std::size_t at = 0;
  const auto bytes = nested_overflow_file(&at);
  const std::string e = refusal(bytes, "nest.ulg");
  // d is 32768 bytes; c = 32768 x d is the first that cannot fit.
  expect_contains(
      e, {where("nest.ulg", at) + ": format 'c', field 'd[32768] d'", "32768 x 32768 bytes",
          "larger than 65535 bytes", "format defined at byte 37"});
}

TEST(ULogHostile, RecursiveFormatsAreRefused) {
  Bytes f = ulog_header();
  format(f, "self:uint64_t timestamp;self next");
  const std::size_t at = f.size();
  subscribe(f, "self", 0);
  expect_contains(refusal(f.bytes(), "self.ulg"),
                  {where("self.ulg", at) + ": format 'self' contains itself"});

  Bytes g = ulog_header();
  format(g, "a:uint64_t timestamp;b[2] b");
  format(g, "b:float x;a back");
  const std::size_t at_g = g.size();
  subscribe(g, "a", 0);
  expect_contains(refusal(g.bytes(), "ab.ulg"),
                  {where("ab.ulg", at_g) + ": format 'a' contains itself"});
}

TEST(ULogHostile, DeepNestingIsRefused) {
  Bytes f = ulog_header();
  for (int i = 0; i < 40; ++i) {
    std::string definition = "f";
    definition += std::to_string(i);
    definition += ":f";
    definition += std::to_string(i + 1);
    definition += " x";
    format(f, definition);
  }
  format(f, "f40:uint8_t x");
  subscribe(f, "f0", 0);
  expect_contains(refusal(f.bytes(), "deep.ulg"),
                  {"deep.ulg: byte ", "format 'f32': message formats nest deeper than 32 levels"});
}

TEST(ULogHostile, UnknownTypeIsRefusedNamingFormatAndField) {
  Bytes f = ulog_header();
  format(f, "t:uint64_t timestamp;vec3 position");
  const std::size_t at = f.size();
  subscribe(f, "t", 0);
  expect_contains(refusal(f.bytes(), "u.ulg"),
                  {where("u.ulg", at) + ": format 't', field 'vec3 position': unknown type 'vec3'",
                   "no format 'F' message defines it"});
}

TEST(ULogHostile, ValueWhoseSizeWouldOverflowIsRefused) {
  // 2^61 doubles are 2^64 bytes, 0 in 64-bit arithmetic: the old check accepted an empty value
  // and read 2^61 doubles past it.
  Bytes f = ulog_header();
  message(f, 'I', test::key_value("double[2305843009213693952] x", Bytes()));
  expect_contains(refusal(f.bytes(), "i.ulg"),
                  {"i.ulg: byte 16: value of type double[2305843009213693952] has 0 bytes, "
                   "expected 2305843009213693952 x 8"});
}

TEST(ULogHostile, ColumnNamesBeyondTheCapAreRefusedBeforeTheyAreBuilt) {
  std::size_t at = 0;
  const auto bytes = long_names_file(&at);
  expect_contains(
      refusal(bytes, "names.ulg"),
      {where("names.ulg", at) + ": topic 'out' (multi_id 2)",
       "column names take more than 67108864 bytes", "limit of 67108864 bytes of column names"});
}

TEST(ULogHostile, ColumnsOfAllTopicsAreCapped) {
  // 17 instances of a topic with 65533 columns: 1114061 columns, more than 2^20. The 17th is
  // refused when its first data message arrives.
  Bytes f = ulog_header();
  format(f, "wide:uint8_t[65533] x");
  std::size_t at = 0;
  for (std::uint8_t i = 0; i < 17; ++i) {
    subscribe(f, "wide", i, i);
    if (i == 16) at = f.size();
    data(f, i, 65533, i);
  }
  expect_contains(
      refusal(f.bytes(), "wide.ulg"),
      {where("wide.ulg", at) + ": topic 'wide' (multi_id 16)",
       "adds 65533 columns to the 1048528 of the topics before it", "limit of 1048576 columns"});
}

TEST(ULogHostile, LargestFormatsWithinTheLimitsAreRead) {
  // A data message of 65535 bytes (the most a message holds): msg_id + 65533 values.
  Bytes f = ulog_header();
  format(f, "edge:uint8_t[65533] x");
  format(f, "s:uint16_t a;uint8_t[3] b");
  format(f, "arr:uint64_t timestamp;s[1000] e;uint8_t[2] _padding0");
  subscribe(f, "edge", 1);
  subscribe(f, "arr", 2);
  data(f, 1, 65533, 7);
  Bytes d;
  d.put(std::uint16_t{2}).put(std::uint64_t{5000000});
  for (int i = 0; i < 1000; ++i) {
    d.put(static_cast<std::uint16_t>(i)).put(std::uint8_t{1}).put(std::uint8_t{2});
    d.put(static_cast<std::uint8_t>(i % 256));
  }
  message(f, 'D', d);  // trailing padding left out
  const ULog log = parse_ulog(f.bytes(), "edge.ulg");
  const ULogTopic& edge = log.topic("edge");
  ASSERT_EQ(edge.columns.size(), 65533u);
  EXPECT_EQ(edge.columns.back(), "x[65532]");
  EXPECT_EQ(edge.column("x[65532]"), std::vector<double>{7.0});
  const ULogTopic& arr = log.topic("arr");
  ASSERT_EQ(arr.columns.size(), 1u + 4000u);
  EXPECT_EQ(arr.columns.back(), "e[999].b[2]");
  EXPECT_EQ(arr.column("e[999].a"), std::vector<double>{999.0});
  EXPECT_EQ(arr.column("e[999].b[2]"), std::vector<double>{999.0 - 768.0});
  EXPECT_EQ(arr.timestamp_us, std::vector<std::uint64_t>{5000000});
}

}  // namespace
}  // namespace dronetwin
