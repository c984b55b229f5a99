// Whole text files in and out (text_file.hpp).
#include "dronetwin/logging/text_file.hpp"

#include <cerrno>
#include <fstream>
#include <sstream>
#include <system_error>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

std::string read_text_file(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InvalidArgument(path + ": cannot read " + what + ": it is a directory");
  // A device or a pipe (/dev/zero, a FIFO) never ends or never arrives: refused, not read.
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
    throw InvalidArgument(path + ": cannot read " + what + ": not a regular file");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InvalidArgument(path + ": cannot open " + what + " (" + errno_text() + ")");
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InvalidArgument(path + ": error while reading " + what);
  return text.str();
}

void write_text_file(const std::filesystem::path& path, const std::string& text) {
  errno = 0;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  require(static_cast<bool>(out), path.string(), ": cannot open for writing (", errno_text(), ")");
  out << text;
  out.close();
  require(static_cast<bool>(out), path.string(), ": error while writing (", errno_text(), ")");
}

}  // namespace dronetwin
