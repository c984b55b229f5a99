// Safe output folders (output_folder.hpp): lock, refuse to overwrite or to write over an input,
// write to temporaries, rename into place.
#include "dronetwin/logging/output_folder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/atomic_file.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

constexpr const char* kLockName = ".dronetwin.lock";

std::string partial_name(const std::string& name) { return "." + name + ".partial"; }

}  // namespace

OutputFolder::OutputFolder(fs::path dir, std::vector<std::string> names,
                           const std::vector<std::string>& inputs, bool overwrite, std::string what)
    : dir_(std::move(dir)), names_(std::move(names)), what_(std::move(what)) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  require(!ec && fs::is_directory(dir_), dir_.string(), ": cannot create the output folder (",
          ec ? ec.message() : std::string("a file of that name is in the way"), ")");
  const fs::path lock_path = dir_ / kLockName;
  lock_fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  require(lock_fd_ >= 0, lock_path.string(), ": cannot open the folder's lock file (", errno_text(),
          ")");
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(lock_fd_);
    lock_fd_ = -1;
    require(false, dir_.string(), ": another dronetwin command is writing into this folder (",
            err == EWOULDBLOCK ? std::string("its lock ") + kLockName + " is held"
                               : std::generic_category().message(err),
            "); wait for it or choose another --out");
  }
  // Holding the lock: what is in the folder cannot change under us (from dronetwin).
  try {
    for (const std::string& name : names_) {
      const fs::path out = dir_ / name;
      for (const std::string& input : inputs) {
        require(input.empty() || !same_file(out, input), out.string(), ": the ", what_,
                " would write over its own input ", input, "; choose another output folder");
      }
      require(
          overwrite || !fs::exists(out, ec), out.string(), ": exists (an earlier ", what_,
          "?); choose another output folder or replace it with --force (Python: overwrite=True)");
      fs::remove(dir_ / partial_name(name), ec);  // left by a command that was killed
    }
  } catch (...) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw;
  }
}

OutputFolder::~OutputFolder() {
  std::error_code ec;
  if (!committed_) {
    for (const std::string& name : names_) fs::remove(partial(name), ec);
  }
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

fs::path OutputFolder::partial(const std::string& name) const { return dir_ / partial_name(name); }

void OutputFolder::commit() {
  for (const std::string& name : names_) {
    std::error_code ec;
    if (!fs::exists(partial(name), ec)) continue;
    fs::rename(partial(name), final_path(name), ec);
    require(!ec, final_path(name).string(), ": cannot move the finished ", what_,
            " output into place (", ec.message(), "); it is in ", partial(name).string());
  }
  committed_ = true;
}

}  // namespace dronetwin
