// A ULog file written byte by byte in the test, so that every documented message type and field
// kind is read back against known values: all twelve basic types, a nested type in an array,
// padding (inside a nested type and trailing padding left out of the data), char[n] text,
// multi-instance topics, remove, info / multi-info (continued) / parameters (initial, default
// and changed in the data section), logging and tagged logging, sync, dropout, and appended data
// after a main stream that stops in the middle of a message.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "adapters/ulog_bytes.hpp"
#include "dronetwin/adapters/ulog.hpp"
#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::Bytes;
using test::error_of;
using test::key_value;
using test::message;

/// The "all" message's payload (without msg_id) for a value offset k; trailing padding omitted.
Bytes all_payload(std::uint64_t t_us, int k) {
  Bytes d;
  d.put(t_us)
      .put(static_cast<std::int8_t>(-5 - k))
      .put(static_cast<std::uint8_t>(200 + k))
      .put(static_cast<std::int16_t>(-30000 + k))
      .put(static_cast<std::uint16_t>(60000 + k))
      .put(static_cast<std::int32_t>(-2000000000 + k))
      .put(static_cast<std::uint32_t>(4000000000u + static_cast<unsigned>(k)))
      .put(static_cast<std::int64_t>(-(std::int64_t{1} << 40) - k))
      .put(static_cast<std::uint64_t>((std::uint64_t{1} << 52) + static_cast<unsigned>(k)))
      .put(1.5f + static_cast<float>(k))
      .put(-2.25 - k)
      .put(static_cast<std::uint8_t>(k % 2))
      .put('A')
      .text("abcd");
  for (int j = 0; j < 2; ++j) {  // inner[2]: float x; int16_t[2] y; uint8_t[2] _padding0
    d.put(0.5f * static_cast<float>(j + k))
        .put(static_cast<std::int16_t>(-j))
        .put(static_cast<std::int16_t>(j + 10));
    d.put(std::uint8_t{0xEE}).put(std::uint8_t{0xEE});
  }
  return d;  // "uint8_t[3] _padding1" at the end is left out, as the format allows
}

std::vector<std::uint8_t> synthetic_log() {
  Bytes f = test::ulog_header(1000);
  // Flag bits: appended data; offset patched below.
  const std::size_t flags_at = f.size();
  {
    Bytes p;
    for (int i = 0; i < 8; ++i) p.put(std::uint8_t{0});
    p.put(std::uint8_t{1});
    for (int i = 1; i < 8; ++i) p.put(std::uint8_t{0});
    for (int i = 0; i < 3; ++i) p.put(std::uint64_t{0});
    message(f, 'B', p);
  }
  Bytes fmt_inner, fmt_all;
  fmt_inner.text("inner:float x;int16_t[2] y;uint8_t[2] _padding0;");
  fmt_all.text(
      "all:uint64_t timestamp;int8_t a;uint8_t b;int16_t c;uint16_t d;int32_t e;uint32_t f;"
      "int64_t g;uint64_t h;float i;double j;bool k;char l;char[4] name;inner[2] in;"
      "uint8_t[3] _padding1;");
  message(f, 'F', fmt_all);  // uses "inner" before it is defined: allowed
  message(f, 'F', fmt_inner);
  message(f, 'I', key_value("char[3] sys", Bytes().text("abc")));
  message(f, 'I', key_value("int32_t ver", Bytes().put(std::int32_t{-7})));
  message(f, 'M', key_value("char[3] doc", Bytes().text("abc"), 0));
  message(f, 'M', key_value("char[2] doc", Bytes().text("de"), 1));
  message(f, 'P', key_value("float P1", Bytes().put(1.5f)));
  message(f, 'P', key_value("int32_t P2", Bytes().put(std::int32_t{3})));
  message(f, 'Q', key_value("float P1", Bytes().put(9.0f), 1));
  message(f, 'A', Bytes().put(std::uint8_t{0}).put(std::uint16_t{5}).text("all"));
  message(f, 'A', Bytes().put(std::uint8_t{1}).put(std::uint16_t{6}).text("all"));
  message(f, 'D', Bytes().put(std::uint16_t{5}).append(all_payload(2000000, 0)));
  message(f, 'D', Bytes().put(std::uint16_t{6}).append(all_payload(2100000, 1)));
  message(f, 'R', Bytes().put(std::uint16_t{6}));
  message(f, 'P', key_value("float P1", Bytes().put(2.5f)));
  message(f, 'L', Bytes().put('6').put(std::uint64_t{2200000}).text("hello"));
  message(f, 'C', Bytes().put('3').put(std::uint16_t{7}).put(std::uint64_t{2300000}).text("tag"));
  message(f, 'S',
          Bytes()
              .put(std::uint8_t{0x2F})
              .put(std::uint8_t{0x73})
              .put(std::uint8_t{0x13})
              .put(std::uint8_t{0x20})
              .put(std::uint8_t{0x25})
              .put(std::uint8_t{0x0C})
              .put(std::uint8_t{0xBB})
              .put(std::uint8_t{0x12}));
  message(f, 'O', Bytes().put(std::uint16_t{100}));
  message(f, 'X', Bytes().text("a future message type is skipped"));
  // The main stream stops in the middle of a data message (header says 76 + 2 bytes, 5 follow).
  f.put(std::uint16_t{78}).put('D').put(std::uint16_t{5}).put(std::uint8_t{1}).put(std::uint8_t{2});
  const std::size_t appended = f.size();
  message(f, 'D', Bytes().put(std::uint16_t{5}).append(all_payload(3000000, 2)));
  std::vector<std::uint8_t> out = f.bytes();
  const auto off = static_cast<std::uint64_t>(appended);
  std::memcpy(out.data() + flags_at + 3 + 16, &off, 8);
  return out;
}

TEST(ULogSynthetic, EveryMessageAndFieldKind) {
  const ULog log = parse_ulog(synthetic_log(), "synthetic.ulg");
  EXPECT_EQ(log.version, 1);
  EXPECT_EQ(log.start_timestamp_us, 1000u);
  EXPECT_EQ(log.info.at("sys"), "abc");
  EXPECT_EQ(log.info.at("ver"), "-7");
  ASSERT_EQ(log.info_multiple.at("doc").size(), 1u);
  EXPECT_EQ(log.info_multiple.at("doc")[0], "abcde");
  EXPECT_EQ(log.parameters.at("P1"), 2.5);
  EXPECT_EQ(log.parameters.at("P2"), 3.0);
  ASSERT_EQ(log.parameter_changes.size(), 1u);
  EXPECT_EQ(log.parameter_changes[0].first, "P1");
  ASSERT_EQ(log.messages.size(), 2u);
  EXPECT_EQ(log.messages[0].level, 6);
  EXPECT_EQ(log.messages[0].text, "hello");
  EXPECT_EQ(log.messages[0].timestamp_us, 2200000u);
  EXPECT_EQ(log.messages[1].tag, 7);
  EXPECT_EQ(log.messages[1].text, "tag");
  EXPECT_EQ(log.dropout_count, 1u);
  EXPECT_EQ(log.dropout_total_ms, 100u);

  ASSERT_EQ(log.topics.size(), 2u);
  const ULogTopic& t0 = log.topic("all", 0);
  const ULogTopic& t1 = log.topic("all", 1);
  const std::vector<std::string> names = {
      "timestamp",  "a",          "b",       "c",          "d",         "e", "f",
      "g",          "h",          "i",       "j",          "k",         "l", "in[0].x",
      "in[0].y[0]", "in[0].y[1]", "in[1].x", "in[1].y[0]", "in[1].y[1]"};
  EXPECT_EQ(t0.columns, names);  // no text (name) and no padding columns
  // Main stream: one message; the cut-off one is dropped; the appended one is read.
  ASSERT_EQ(t0.num_messages(), 2u);
  ASSERT_EQ(t1.num_messages(), 1u);
  EXPECT_EQ(t0.timestamp_us, (std::vector<std::uint64_t>{2000000, 3000000}));
  for (std::size_t r = 0; r < 2; ++r) {
    const double k = r == 0 ? 0.0 : 2.0;
    EXPECT_DOUBLE_EQ(t0.column("timestamp")[r], r == 0 ? 2.0 : 3.0);
    EXPECT_EQ(t0.column("a")[r], -5 - k);
    EXPECT_EQ(t0.column("b")[r], 200 + k);
    EXPECT_EQ(t0.column("c")[r], -30000 + k);
    EXPECT_EQ(t0.column("d")[r], 60000 + k);
    EXPECT_EQ(t0.column("e")[r], -2000000000 + k);
    EXPECT_EQ(t0.column("f")[r], 4000000000.0 + k);
    EXPECT_EQ(t0.column("g")[r], -1099511627776.0 - k);
    EXPECT_EQ(t0.column("h")[r], 4503599627370496.0 + k);
    EXPECT_EQ(t0.column("i")[r], 1.5 + k);
    EXPECT_EQ(t0.column("j")[r], -2.25 - k);
    EXPECT_EQ(t0.column("k")[r], 0.0);
    EXPECT_EQ(t0.column("l")[r], 65.0);
    EXPECT_EQ(t0.column("in[1].x")[r], 0.5 * (1 + k));
    EXPECT_EQ(t0.column("in[1].y[0]")[r], -1.0);
    EXPECT_EQ(t0.column("in[1].y[1]")[r], 11.0);
  }
  EXPECT_EQ(t1.column("k")[0], 1.0);
  EXPECT_EQ(t1.column("a")[0], -6.0);
}

TEST(ULogSynthetic, DataAfterRemoveAndBadSizesAreErrors) {
  auto bytes = synthetic_log();
  // A data message for msg_id 6 after its 'R': append one to a copy without appended data.
  // Simplest: change the msg_id of the appended message (at the end) to 6.
  const std::size_t last = bytes.size() - (3 + 2 + all_payload(0, 0).size());
  bytes[last + 3] = 6;
  std::string e = error_of([&] { (void)parse_ulog(bytes, "x.ulg"); });
  EXPECT_NE(e.find("x.ulg: byte " + std::to_string(last) + ": data message for msg_id 6"),
            std::string::npos)
      << e;
  // A data message shorter than its fields need.
  bytes = synthetic_log();
  bytes[last] = static_cast<std::uint8_t>(bytes[last] - 5);  // claim 5 fewer bytes
  // erase, not resize: GCC 12 cannot prove size() >= 5 and warns about a huge memset.
  bytes.erase(bytes.end() - 5, bytes.end());
  e = error_of([&] { (void)parse_ulog(bytes, "y.ulg"); });
  EXPECT_NE(e.find("y.ulg: byte " + std::to_string(last) + ": data message of 'all' has 71 bytes"),
            std::string::npos)
      << e;
}

}  // namespace
}  // namespace dronetwin
