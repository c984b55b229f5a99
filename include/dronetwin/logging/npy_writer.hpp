#pragma once
// A stack of float32 frames written as one NumPy .npy file (format version 1.0, little-endian
// '<f4', C order, shape (frames, rows, cols)) while they are produced: numpy.load() reads it,
// and memory stays one frame whatever the run's length. The frame count is not known until the
// end, so the header is written with room for any count and rewritten by close().
//
//   NpyFrameWriter out(folder.partial("depth.npy").string(), 48, 64);
//   out.append(frame.data());          // 48 * 64 floats, row-major
//   out.close();                       // header now says (n, 48, 64)
//
// Errors (cannot open, a failed write, a full disk) are InvalidArgument naming the file.

#include <cstdint>
#include <cstdio>
#include <string>

namespace dronetwin {

class NpyFrameWriter {
 public:
  NpyFrameWriter(std::string path, std::int64_t rows, std::int64_t cols);
  ~NpyFrameWriter();
  NpyFrameWriter(const NpyFrameWriter&) = delete;
  NpyFrameWriter& operator=(const NpyFrameWriter&) = delete;

  /// One frame of rows * cols floats, row-major.
  void append(const float* frame);
  /// Writes the final header and closes the file; later appends are errors. Idempotent.
  void close();

  std::int64_t frames() const { return frames_; }
  const std::string& path() const { return path_; }

  /// The .npy header for (frames, rows, cols) float32, padded with spaces so that the data
  /// starts at byte 128 for any frame count below 10^20 (a multiple of 64, as numpy aligns).
  static std::string header(std::int64_t frames, std::int64_t rows, std::int64_t cols);

 private:
  std::string path_;
  std::int64_t rows_, cols_;
  std::int64_t frames_ = 0;
  std::FILE* file_ = nullptr;
  bool write_error_ = false;
};

}  // namespace dronetwin
