#include "dronetwin/logging/npy_writer.hpp"

#include <bit>
#include <cerrno>
#include <cstring>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

constexpr std::size_t kHeaderBytes = 128;

}  // namespace

std::string NpyFrameWriter::header(std::int64_t frames, std::int64_t rows, std::int64_t cols) {
  // Magic, version 1.0, the dictionary's length (little-endian uint16), the dictionary padded
  // with spaces and ended by a newline (the format's specification, numpy.lib.format).
  std::string dict = detail::concat("{'descr': '<f4', 'fortran_order': False, 'shape': (", frames,
                                    ", ", rows, ", ", cols, "), }");
  const std::size_t dict_bytes = kHeaderBytes - 10;
  require(dict.size() < dict_bytes, "NpyFrameWriter: shape too large for the header");
  dict.append(dict_bytes - 1 - dict.size(), ' ');
  dict.push_back('\n');
  std::string h = "\x93NUMPY";
  h.push_back('\x01');
  h.push_back('\x00');
  h.push_back(static_cast<char>(dict_bytes & 0xff));
  h.push_back(static_cast<char>((dict_bytes >> 8) & 0xff));
  return h + dict;
}

NpyFrameWriter::NpyFrameWriter(std::string path, std::int64_t rows, std::int64_t cols)
    : path_(std::move(path)), rows_(rows), cols_(cols) {
  static_assert(std::endian::native == std::endian::little, "the .npy data is written as '<f4'");
  require(rows > 0 && cols > 0, path_, ": a frame needs rows and columns, got ", rows, " x ", cols);
  errno = 0;
  file_ = std::fopen(path_.c_str(), "wb");
  require(file_ != nullptr, path_, ": cannot open for writing (", std::strerror(errno), ")");
  const std::string h = header(0, rows_, cols_);
  if (std::fwrite(h.data(), 1, h.size(), file_) != h.size()) write_error_ = true;
}

NpyFrameWriter::~NpyFrameWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void NpyFrameWriter::append(const float* frame) {
  require(file_ != nullptr, path_, ": append after close()");
  const auto n = static_cast<std::size_t>(rows_ * cols_);
  if (std::fwrite(frame, sizeof(float), n, file_) != n) write_error_ = true;
  ++frames_;
}

void NpyFrameWriter::close() {
  if (file_ == nullptr) return;
  const std::string h = header(frames_, rows_, cols_);
  if (std::fseek(file_, 0, SEEK_SET) != 0 || std::fwrite(h.data(), 1, h.size(), file_) != h.size())
    write_error_ = true;
  const bool close_failed = std::fclose(file_) != 0;
  file_ = nullptr;
  require(!write_error_ && !close_failed, path_, ": error while writing the frames");
}

}  // namespace dronetwin
