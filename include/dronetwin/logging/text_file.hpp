#pragma once
// Whole text files in and out, with errors that name the file and say why.
//
//   std::string text = read_text_file("models/qdrone2.yaml", "model file");
//   write_text_file("out/summary.json", text);
//
// Trap: write_text_file() truncates an existing file; callers that must not lose a user's data
// check their output paths first.

#include <filesystem>
#include <string>

namespace dronetwin {

/// The file's bytes. InvalidArgument "<path>: cannot open <what> (<reason>)" when it is missing,
/// unreadable or a directory.
std::string read_text_file(const std::string& path, const std::string& what);

/// Creates or truncates `path` and writes `text`; InvalidArgument naming the file otherwise.
void write_text_file(const std::filesystem::path& path, const std::string& text);

}  // namespace dronetwin
