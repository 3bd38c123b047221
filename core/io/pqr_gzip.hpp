#pragma once
/// @file pqr_gzip.hpp
/// Private helper of the PQR reader: bounded gzip decompression with zlib.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::detail {

/// True when `bytes` start with the gzip magic 1f 8b.
bool has_gzip_magic(std::string_view bytes) noexcept;

/// Decompresses one or more concatenated gzip members. Errors: errc::invalid_input (corrupt or truncated stream,
/// or trailing bytes that are not a gzip member), errc::limit_exceeded as soon as the output passes max_bytes,
/// errc::internal_error when zlib cannot allocate its state.
result<std::string> gunzip(std::string_view compressed, std::size_t max_bytes);

/// The whole file, or an error: errc::io_error naming the path when it cannot be opened or read,
/// errc::limit_exceeded as soon as it passes max_bytes (so memory stays bounded).
result<std::string> read_file_bounded(const std::filesystem::path& path, std::size_t max_bytes);

}  // namespace tracemesh::detail
