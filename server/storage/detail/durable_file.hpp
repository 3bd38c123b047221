#pragma once
/// @file durable_file.hpp
/// Small durable files for the job store (conventions §12, ccache AtomicFile): a file is written to a temporary
/// name in its own directory, fsync'd, renamed over the final name and the directory fsync'd, so a crash or
/// SIGKILL at any moment leaves the old file or the new one, never a mix. Sealed files carry a magic, their payload
/// length and the payload's SHA-256, so a truncated or damaged file is recognised and never used.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::server::detail {

/// The prefix of temporary files; a directory's owner removes leftovers (of a killed writer) at start.
inline constexpr std::string_view durable_temp_prefix = ".tmp-";

/// The POSIX steps both durable stores (this job store, the result cache) build on, retried on EINTR:
/// open(2) with O_CLOEXEC (−1 and errno on failure); every byte written (false and errno on failure); fsync of a
/// directory, which makes a rename or removal in it durable.
int open_retrying(const char* path, int flags, unsigned mode = 0);
bool write_all(int fd, std::string_view bytes);
bool fsync_directory(const std::filesystem::path& dir);

/// Writes `bytes` to `path` atomically and durably. @return errc::io_error naming the step and path on failure
/// (no temporary file is left then).
status write_file_durably(const std::filesystem::path& path, std::string_view bytes);

/// Removes `path` and makes the removal durable (fsync of its directory). A missing file is not an error.
status remove_file_durably(const std::filesystem::path& path);

/// The whole file, or std::nullopt when it cannot be opened or read.
std::optional<std::string> read_whole_file(const std::filesystem::path& path);

/// Creates `dir` (and its parents) if needed and proves it usable: it is a directory and a probe file can be
/// written, fsync'd and removed in it. @return errc::io_error with one line naming `what`, the path and the reason.
status ensure_writable_directory(const std::filesystem::path& dir, std::string_view what);

/// magic(8) | payload length u64 LE | SHA-256(payload) | payload.
std::string seal(std::string_view magic8, std::string_view payload);
/// The payload of a sealed file, or std::nullopt when the magic, the length or the checksum does not match.
std::optional<std::string> unseal(std::string_view magic8, std::string_view sealed);

}  // namespace tracemesh::server::detail
