// Atomic output files (atomic_file.hpp): POSIX open/write/fsync/rename, so every failure has
// its errno.
#include "dronetwin/logging/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <system_error>

#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

std::filesystem::path folder_of(const std::filesystem::path& p) {
  return p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
}

}  // namespace

AtomicFileWriter::AtomicFileWriter(std::filesystem::path path) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  require(!path_.empty() && path_.has_filename(), "output '", path_.string(),
          "': expected a file name");
  std::error_code ec;
  require(!fs::is_directory(path_, ec), path_.string(), ": cannot write: it is a directory");
  const fs::path folder = folder_of(path_);
  require(fs::is_directory(folder, ec), path_.string(), ": cannot write: the folder ",
          folder.string(), " does not exist");
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100 && fd_ < 0; ++attempt) {
    // Built with += (GCC 12 warns falsely of overlapping copies in "." + string).
    std::string name(1, '.');
    name += path_.filename().string();
    name += '.';
    name += std::to_string(::getpid());
    name += '.';
    name += std::to_string(counter++);
    name += ".tmp";
    temporary_ = folder / name;
    errno = 0;
    fd_ = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ < 0 && errno != EEXIST) break;
  }
  if (fd_ < 0) {
    const int error = errno;
    throw InvalidArgument(path_.string() + ": cannot write (cannot create a file in " +
                          folder.string() + ": " + errno_text(error) + ")");
  }
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!temporary_.empty()) ::unlink(temporary_.c_str());
}

void AtomicFileWriter::commit(const std::string& text) {
  require(fd_ >= 0, path_.string(), ": commit() called twice");
  const auto fail = [&](const std::string& what, int error) {
    ::close(fd_);
    fd_ = -1;
    ::unlink(temporary_.c_str());
    temporary_.clear();
    throw InvalidArgument(path_.string() + ": " + what + " (" + errno_text(error) +
                          "); the file was not changed");
  };
  const char* p = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    errno = 0;
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("error while writing", n < 0 ? errno : EIO);
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd_) != 0) fail("error while writing", errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const int error = errno;
    ::unlink(temporary_.c_str());
    temporary_.clear();
    throw InvalidArgument(path_.string() + ": error while writing (" + errno_text(error) +
                          "); the file was not changed");
  }
  if (::rename(temporary_.c_str(), path_.c_str()) != 0) {
    const int error = errno;
    ::unlink(temporary_.c_str());
    temporary_.clear();
    throw InvalidArgument(path_.string() + ": cannot replace it (" + errno_text(error) +
                          "); the file was not changed");
  }
  temporary_.clear();
}

void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  AtomicFileWriter out(path);
  out.commit(text);
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  namespace fs = std::filesystem;
  std::error_code ea, eb;
  if (fs::exists(a, ea) && fs::exists(b, eb)) {
    std::error_code ec;
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  std::error_code ca, cb;
  const fs::path x = fs::weakly_canonical(fs::absolute(a), ca);
  const fs::path y = fs::weakly_canonical(fs::absolute(b), cb);
  return !ca && !cb ? x == y
                    : fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
}

void require_not_an_input(const std::string& what, const std::filesystem::path& output,
                          const std::vector<NamedPath>& inputs) {
  for (const NamedPath& in : inputs) {
    if (in.path.empty() || output.empty()) continue;
    require(!same_file(output, in.path), what, " ", output.string(), ": is also the ", in.name,
            " (", in.path.string(), "); an output never overwrites an input");
  }
}

}  // namespace dronetwin
