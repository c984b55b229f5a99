// Tests of the PX4 ULog reader (include/dronetwin/adapters/ulog.hpp) on a real PX4 v1.9 flight log
// (tests/data/real/px4-ulog-rs/esc_status_log.ulg, MIT, Auterion / px4-ulog-rs authors): topic
// list, message counts against an independent scan of the message headers, physical plausibility,
// and truncated / corrupted copies rejected with the byte offset of the bad message.
#include "dronetwin/adapters/ulog.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;
using test::error_of;

const std::string kLog = test::source_path("tests/data/real/px4-ulog-rs/esc_status_log.ulg");

std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Offsets and types of every message, found by walking the size fields only (no decoding).
struct Header {
  std::size_t offset;
  std::uint16_t size;
  char type;
};
std::vector<Header> scan(const std::vector<std::uint8_t>& b) {
  std::vector<Header> out;
  for (std::size_t pos = 16; pos + 3 <= b.size();) {
    const std::uint16_t size = static_cast<std::uint16_t>(b[pos] | (b[pos + 1] << 8));
    out.push_back({pos, size, static_cast<char>(b[pos + 2])});
    pos += 3u + size;
  }
  return out;
}

class ULogFile : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { log_ = new ULog(read_ulog(kLog)); }
  static void TearDownTestSuite() {
    delete log_;
    log_ = nullptr;
  }
  static ULog* log_;
};
ULog* ULogFile::log_ = nullptr;

TEST_F(ULogFile, HeaderInfoAndParameters) {
  EXPECT_EQ(log_->version, 1);
  EXPECT_EQ(log_->info.at("sys_name"), "PX4");
  EXPECT_EQ(log_->info.at("ver_hw"), "PX4_FMU_V3");
  // Parameters are float or int32; every PX4 log has the multicopter hover thrust parameter.
  ASSERT_TRUE(log_->parameters.count("MPC_THR_HOVER"));
  EXPECT_GT(log_->parameters.at("MPC_THR_HOVER"), 0.0);
  EXPECT_LT(log_->parameters.at("MPC_THR_HOVER"), 1.0);
}

TEST_F(ULogFile, TopicsAndCountsMatchAnIndependentScan) {
  for (const char* name : {"esc_status", "vehicle_attitude", "vehicle_local_position",
                           "battery_status", "sensor_combined"}) {
    EXPECT_TRUE(log_->has_topic(name)) << name;
  }
  // Multi-instance topic: three actuator_outputs instances.
  EXPECT_TRUE(log_->has_topic("actuator_outputs", 0));
  EXPECT_TRUE(log_->has_topic("actuator_outputs", 2));
  EXPECT_FALSE(log_->has_topic("actuator_outputs", 3));

  // Count 'D' messages by msg_id from the raw headers and map msg_id -> (name, multi_id) via 'A'.
  const auto bytes = file_bytes(kLog);
  std::map<std::uint16_t, std::pair<std::string, int>> ids;
  std::map<std::pair<std::string, int>, std::size_t> counts;
  for (const Header& h : scan(bytes)) {
    const std::uint8_t* p = bytes.data() + h.offset + 3;
    if (h.type == 'A') {
      const std::uint16_t id = static_cast<std::uint16_t>(p[1] | (p[2] << 8));
      ids[id] = {std::string(reinterpret_cast<const char*>(p + 3), h.size - 3u), p[0]};
    } else if (h.type == 'D') {
      ++counts[ids.at(static_cast<std::uint16_t>(p[0] | (p[1] << 8)))];
    }
  }
  ASSERT_EQ(counts.size(), log_->topics.size());
  for (const ULogTopic& t : log_->topics) {
    EXPECT_EQ(t.num_messages(), counts.at({t.name, t.multi_id})) << t.name << "/" << t.multi_id;
  }
  // About 40 s of flight: attitude near 28 Hz, ESC status near 3 Hz (README).
  EXPECT_GT(log_->topic("vehicle_attitude").num_messages(), 1000u);
  EXPECT_GT(log_->topic("esc_status").num_messages(), 100u);
}

TEST_F(ULogFile, FlattenedNamesAndTimestamps) {
  const ULogTopic& esc = log_->topic("esc_status");
  EXPECT_EQ(esc.columns.front(), "timestamp");
  EXPECT_TRUE(esc.has_column("esc[0].esc_rpm"));
  EXPECT_TRUE(esc.has_column("esc[7].esc_voltage"));
  for (const std::string& c : esc.columns) EXPECT_EQ(c.find("_padding"), std::string::npos) << c;
  EXPECT_TRUE(log_->topic("vehicle_attitude").has_column("q[3]"));
  for (const ULogTopic& t : log_->topics) {
    ASSERT_EQ(t.timestamp_us.size(), t.num_messages()) << t.name;
    const auto& ts = t.column("timestamp");
    for (std::size_t i = 0; i < ts.size(); ++i) {
      EXPECT_DOUBLE_EQ(ts[i], static_cast<double>(t.timestamp_us[i]) * 1e-6);
      if (i > 0) {
        EXPECT_GE(t.timestamp_us[i], t.timestamp_us[i - 1]) << t.name << " row " << i;
      }
    }
    // Within the ~40 s log (a command queued before logging started may precede the header's
    // start time by a little, so allow 1 s).
    EXPECT_GT(ts.front(), static_cast<double>(log_->start_timestamp_us) * 1e-6 - 1.0) << t.name;
    EXPECT_LT(ts.back(), static_cast<double>(log_->start_timestamp_us) * 1e-6 + 60.0) << t.name;
  }
  EXPECT_THROW(esc.column("esc_rpm"), InvalidArgument);
  EXPECT_NE(error_of([&] { (void)log_->topic("no_such_topic"); }).find("no_such_topic"),
            std::string::npos);
}

TEST_F(ULogFile, PhysicallyPlausibleValues) {
  const ULogTopic& att = log_->topic("vehicle_attitude");
  for (std::size_t i = 0; i < att.num_messages(); ++i) {
    double n2 = 0.0;
    for (int k = 0; k < 4; ++k) n2 += std::pow(att.column("q[" + std::to_string(k) + "]")[i], 2);
    EXPECT_NEAR(std::sqrt(n2), 1.0, 1e-6) << "row " << i;  // float32 unit quaternions
  }
  // Four UAVCAN ESCs of a 6S quad: rpm within 0..10000, all spinning in flight; slots 4..7 empty.
  const ULogTopic& esc = log_->topic("esc_status");
  for (int k = 0; k < 4; ++k) {
    const auto& rpm = esc.column("esc[" + std::to_string(k) + "].esc_rpm");
    const auto& volt = esc.column("esc[" + std::to_string(k) + "].esc_voltage");
    for (std::size_t i = 0; i < rpm.size(); ++i) {
      EXPECT_GT(rpm[i], 1000.0);
      EXPECT_LT(rpm[i], 10000.0);
      EXPECT_GT(volt[i], 6 * 3.3);  // 6S pack between 3.3 and 4.25 V per cell
      EXPECT_LT(volt[i], 6 * 4.25);
    }
  }
  for (double v : esc.column("esc[5].esc_rpm")) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(esc.column("esc_count").front(), 4.0);
}

class ULogCorrupt : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dronetwin_ulog_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    bytes_ = file_bytes(kLog);
    headers_ = scan(bytes_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::vector<std::uint8_t>& b) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
    return path;
  }
  /// First message of a type at or after the middle of the file.
  const Header& middle(char type) const {
    for (const Header& h : headers_) {
      if (h.type == type && h.offset > bytes_.size() / 2) return h;
    }
    throw std::logic_error("no such message");
  }
  fs::path dir_;
  std::vector<std::uint8_t> bytes_;
  std::vector<Header> headers_;
};

TEST_F(ULogCorrupt, TruncatedInsideAMessage) {
  const Header& h = middle('D');
  std::vector<std::uint8_t> cut(bytes_.begin(), bytes_.begin() + static_cast<long>(h.offset + 5));
  const std::string path = write("cut.ulg", cut);
  const std::string e = error_of([&] { (void)read_ulog(path); });
  EXPECT_NE(e.find(path), std::string::npos) << e;
  EXPECT_NE(e.find("byte " + std::to_string(h.offset) + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
}

TEST_F(ULogCorrupt, TruncatedInsideAHeader) {
  const Header& h = middle('D');
  std::vector<std::uint8_t> cut(bytes_.begin(), bytes_.begin() + static_cast<long>(h.offset + 2));
  const std::string e = error_of([&] { (void)read_ulog(write("cut2.ulg", cut)); });
  EXPECT_NE(e.find("byte " + std::to_string(h.offset) + ": truncated message header"),
            std::string::npos)
      << e;
}

TEST_F(ULogCorrupt, BadTypeByteAndUnknownMsgId) {
  const Header& h = middle('D');
  auto bad = bytes_;
  bad[h.offset + 2] = 0x07;
  std::string e = error_of([&] { (void)read_ulog(write("type.ulg", bad)); });
  EXPECT_NE(e.find("byte " + std::to_string(h.offset) + ": invalid message type"),
            std::string::npos)
      << e;

  bad = bytes_;
  bad[h.offset + 3] = 0xFF;  // msg_id 0xFFxx: never subscribed
  bad[h.offset + 4] = 0xFF;
  e = error_of([&] { (void)read_ulog(write("id.ulg", bad)); });
  EXPECT_NE(e.find("byte " + std::to_string(h.offset) + ": data message for msg_id 65535"),
            std::string::npos)
      << e;
}

TEST_F(ULogCorrupt, BadMagicAndShortFile) {
  auto bad = bytes_;
  bad[1] = 'X';
  EXPECT_NE(error_of([&] { (void)read_ulog(write("magic.ulg", bad)); }).find("byte 0: not a ULog"),
            std::string::npos);
  std::vector<std::uint8_t> tiny(bytes_.begin(), bytes_.begin() + 10);
  EXPECT_NE(error_of([&] { (void)read_ulog(write("tiny.ulg", tiny)); }).find("too short"),
            std::string::npos);
  EXPECT_NE(error_of([&] { (void)read_ulog((dir_ / "missing.ulg").string()); }).find("cannot open"),
            std::string::npos);
}

TEST_F(ULogCorrupt, FormatFieldWithMalformedArray) {
  // "float[3] q" -> "float[x] q" in the first format message with an array: malformed size.
  for (const Header& h : headers_) {
    if (h.type != 'F') continue;
    auto bad = bytes_;
    auto* first = bad.data() + h.offset + 3;
    auto* bracket = static_cast<std::uint8_t*>(std::memchr(first, '[', h.size));
    if (!bracket) continue;
    bracket[1] = 'x';
    const std::string e = error_of([&] { (void)read_ulog(write("fmt.ulg", bad)); });
    EXPECT_NE(e.find("byte " + std::to_string(h.offset) + ":"), std::string::npos) << e;
    return;
  }
  FAIL() << "no format message with an array";
}

}  // namespace
}  // namespace dronetwin
