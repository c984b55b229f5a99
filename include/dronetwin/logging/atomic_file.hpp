#pragma once
// Output files that appear complete or not at all, and outputs that never overwrite inputs.
//
//   AtomicFileWriter out("out/fitted.yaml");   // fails now if out/ is missing or read-only
//   std::string text = long_computation();
//   out.commit(text);                           // out/fitted.yaml replaced in one rename()
//
// The text goes to a temporary file in the same directory (".fitted.yaml.<pid>.<n>.tmp"), which
// rename() puts in place on commit(): a reader sees the old file or the new one, never half of
// one, and a crash or a full disk leaves the old file as it was. The temporary file is created in
// the constructor, so a missing folder or a permission problem shows before the work that makes
// the text; a writer destroyed without commit() removes it. Every error names the file and says
// why (the system's reason: "No such file or directory", "Permission denied", "No space left on
// device", ...).
//
// One file on its own (`dronetwin fit -o`, a model file). A command that writes a folder of
// outputs uses OutputFolder (output_folder.hpp), which also locks the folder; both refuse an
// output that is an input with same_file() below.
//
// Trap: rename() replaces a symbolic link at `path` by a regular file (the link's target is left
// alone), and the new file gets the default permissions, not the old file's.

#include <filesystem>
#include <string>
#include <vector>

namespace dronetwin {

class AtomicFileWriter {
 public:
  /// Creates the temporary file next to `path`. InvalidArgument when `path` is a directory or
  /// the temporary file cannot be created (naming `path`, its folder and the reason).
  explicit AtomicFileWriter(std::filesystem::path path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// Writes `text`, flushes it to the disk and renames the temporary file to path(). Once only.
  /// InvalidArgument naming the file and the reason on any failure (the temporary file is then
  /// removed and path() left as it was).
  void commit(const std::string& text);

 private:
  std::filesystem::path path_, temporary_;
  int fd_ = -1;
};

/// Writes `text` to `path` through an AtomicFileWriter.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

/// True when `a` and `b` name the same file: the same existing file (std::filesystem::equivalent:
/// through symbolic links, `..` and hard links), or the same path once made absolute with
/// symbolic links and `..` resolved (std::filesystem::weakly_canonical) when either does not exist.
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b);

/// InvalidArgument "<what> <output>: is also <input's name> (<input>); an output never overwrites
/// an input" when `output` is the same file as one of `inputs` ({name, path}; empty paths are
/// skipped).
struct NamedPath {
  std::string name;
  std::filesystem::path path;
};
void require_not_an_input(const std::string& what, const std::filesystem::path& output,
                          const std::vector<NamedPath>& inputs);

}  // namespace dronetwin
