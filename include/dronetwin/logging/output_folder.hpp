#pragma once
// The files a command writes into one output folder, written so that a user's data is never lost:
//
// - the folder is created if needed and locked for as long as the OutputFolder lives (an advisory
//   flock() on DIR/.dronetwin.lock): a second dronetwin writing into the same folder fails at once
//   with a message that names the folder, instead of interleaving rows with the first;
// - an output that already exists is refused unless `overwrite` (the CLI's --force), and an output
//   that is one of the command's inputs (the same file after resolving links and `..`) is always
//   refused;
// - every output is written to a temporary name beside it (DIR/.NAME.partial) and renamed into
//   place by commit(), which the file system does atomically: a reader never sees a half-written
//   file, and a command that dies mid-way leaves the previous files as they were.
//
//   OutputFolder out("out/hover", {"log.csv", "log.json", "summary.json"}, {experiment, model},
//                    /*overwrite=*/false, "run");
//   write_text_file(out.partial("summary.json"), text);    // ... and the others
//   out.commit();                                           // all of them, in the order given
//
// Trap: the lock is advisory and per folder; it keeps dronetwin processes apart, not an editor.
// Temporaries of a command that was killed are removed by the next one that locks the folder.

#include <filesystem>
#include <string>
#include <vector>

namespace dronetwin {

class OutputFolder {
 public:
  /// Creates and locks `dir` and checks `names` (file names inside it) against what exists and
  /// against `inputs` (paths of files the command reads). InvalidArgument naming the folder or
  /// file and what to do otherwise. `what` names the command in messages ("run", "import").
  OutputFolder(std::filesystem::path dir, std::vector<std::string> names,
               const std::vector<std::string>& inputs, bool overwrite, std::string what);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  /// Where output `name` is written until commit().
  std::filesystem::path partial(const std::string& name) const;
  /// Where output `name` ends up.
  std::filesystem::path final_path(const std::string& name) const { return dir_ / name; }
  /// Renames every written partial file into place, in the order of `names` (write the file that
  /// marks a finished command, e.g. summary.json, last). Outputs never written are skipped.
  void commit();

 private:
  std::filesystem::path dir_;
  std::vector<std::string> names_;
  std::string what_;
  int lock_fd_ = -1;
  bool committed_ = false;
};

}  // namespace dronetwin
