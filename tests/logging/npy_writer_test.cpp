// NpyFrameWriter: the file is a valid .npy by the format's own rules (magic, version 1.0, header
// length, a dictionary giving '<f4', C order and the final shape, data from a 64-byte aligned
// offset), the frames read back bit for bit, and misuse and unwritable paths are named.

#include "dronetwin/logging/npy_writer.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(NpyFrameWriter, WritesAValidFileWithTheFinalShape) {
  test::TempDir dir;
  const std::string path = (dir.path() / "frames.npy").string();
  std::vector<float> frame(3 * 5);
  {
    NpyFrameWriter out(path, 3, 5);
    for (int f = 0; f < 7; ++f) {
      for (std::size_t i = 0; i < frame.size(); ++i)
        frame[i] = 0.25f * static_cast<float>(f) + static_cast<float>(i) * 1e-3f;
      out.append(frame.data());
    }
    out.close();
    out.close();  // idempotent
    EXPECT_EQ(out.frames(), 7);
    EXPECT_THROW(out.append(frame.data()), InvalidArgument);
  }
  const std::string bytes = read_bytes(path);
  ASSERT_GE(bytes.size(), 10u);
  EXPECT_EQ(bytes.substr(0, 6), "\x93NUMPY");
  EXPECT_EQ(bytes[6], '\x01');
  EXPECT_EQ(bytes[7], '\x00');
  const std::size_t header_len =
      static_cast<unsigned char>(bytes[8]) + 256u * static_cast<unsigned char>(bytes[9]);
  const std::size_t data_at = 10 + header_len;
  EXPECT_EQ(data_at % 64, 0u);
  const std::string dict = bytes.substr(10, header_len);
  EXPECT_EQ(dict.back(), '\n');
  EXPECT_NE(dict.find("'descr': '<f4'"), std::string::npos) << dict;
  EXPECT_NE(dict.find("'fortran_order': False"), std::string::npos) << dict;
  EXPECT_NE(dict.find("'shape': (7, 3, 5)"), std::string::npos) << dict;
  ASSERT_EQ(bytes.size(), data_at + 7 * 15 * sizeof(float));
  for (int f = 0; f < 7; ++f) {
    for (std::size_t i = 0; i < 15; ++i) {
      float v = 0.0f;
      std::memcpy(&v, bytes.data() + data_at + (static_cast<std::size_t>(f) * 15 + i) * 4, 4);
      EXPECT_EQ(v, 0.25f * static_cast<float>(f) + static_cast<float>(i) * 1e-3f);
    }
  }
}

TEST(NpyFrameWriter, AnEmptyStackAndBadArgumentsAreHandled) {
  test::TempDir dir;
  const std::string path = (dir.path() / "none.npy").string();
  {
    NpyFrameWriter out(path, 2, 2);
    out.close();
  }
  EXPECT_NE(read_bytes(path).find("'shape': (0, 2, 2)"), std::string::npos);
  const std::string bad = test::error_of([&] { NpyFrameWriter w(path, 0, 2); });
  EXPECT_NE(bad.find("a frame needs rows and columns, got 0 x 2"), std::string::npos) << bad;
  const std::string missing = (dir.path() / "no" / "such" / "x.npy").string();
  const std::string m = test::error_of([&] { NpyFrameWriter w(missing, 2, 2); });
  EXPECT_NE(m.find(missing + ": cannot open for writing"), std::string::npos) << m;
  // The header has room for any count an int64 holds.
  EXPECT_EQ(NpyFrameWriter::header(9223372036854775807LL, 4096, 4096).size(), 128u);
}

}  // namespace
}  // namespace dronetwin
