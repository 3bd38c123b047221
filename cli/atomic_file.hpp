#pragma once
/// @file atomic_file.hpp
/// Writing output files so that a failed or interrupted run never leaves a partial file behind: the bytes go to a
/// temporary file in the destination's directory, are flushed to disk, then renamed over the destination.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"

namespace tracemesh::cli {

/// One file to write: where, and what (the bytes must outlive the call).
struct file_contents {
  std::filesystem::path path;
  std::string_view bytes;
};

/// Replaces (or creates) `path` with `bytes` atomically. On any failure the destination is left as it was, the
/// temporary file is removed and errc::io_error names the path and the system error.
status write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

/// write_file_atomically for several files (e.g. an MSMS .vert/.face pair): every file is written to its temporary
/// first and only then renamed, so a failed write (disk full, permissions) changes none of them. Only a failing
/// rename, after the data is safely on disk, can leave the earlier files replaced and the later ones not.
status write_files_atomically(const std::vector<file_contents>& files);

}  // namespace tracemesh::cli
