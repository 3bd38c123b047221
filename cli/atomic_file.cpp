#include "cli/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>

namespace tracemesh::cli {
namespace {

status io_error(const std::filesystem::path& path, const char* what, int error_number) {
  return {errc::io_error, "cannot " + std::string(what) + " " + path.string() + ": " + std::strerror(error_number)};
}

/// A name next to `path` that no other writer (process or thread) uses: ".<name>.tmp-<pid>-<counter>".
std::filesystem::path temporary_path_for(const std::filesystem::path& path) {
  static std::atomic<unsigned> counter{0};
  // Appended piece by piece: g++ 12 raises a false -Wrestrict on `"." + std::string(...)`.
  std::string name = ".";
  name += path.filename().string();
  name += ".tmp-";
  name += std::to_string(::getpid());
  name += '-';
  name += std::to_string(counter.fetch_add(1));
  return path.parent_path() / name;
}

status write_all(int fd, std::string_view bytes, const std::filesystem::path& path) {
  while (!bytes.empty()) {
    const ssize_t written = ::write(fd, bytes.data(), bytes.size());
    if (written < 0) {
      if (errno == EINTR) continue;
      return io_error(path, "write", errno);
    }
    bytes.remove_prefix(static_cast<std::size_t>(written));
  }
  return status::success();
}

/// Writes and fsyncs `bytes` into a new file at `temporary`; removes it on failure.
status write_temporary(const std::filesystem::path& temporary, std::string_view bytes,
                       const std::filesystem::path& destination) {
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) return io_error(destination, "create a file next to", errno);
  status written = write_all(fd, bytes, destination);
  if (written && ::fsync(fd) != 0) written = io_error(destination, "flush", errno);
  if (::close(fd) != 0 && written) written = io_error(destination, "close", errno);
  if (!written) ::unlink(temporary.c_str());
  return written;
}

}  // namespace

status write_files_atomically(const std::vector<file_contents>& files) {
  std::vector<std::filesystem::path> temporaries;
  const auto discard_temporaries = [&temporaries] {
    for (const auto& temporary : temporaries) ::unlink(temporary.c_str());
  };
  for (const file_contents& file : files) {
    const std::filesystem::path temporary = temporary_path_for(file.path);
    if (status written = write_temporary(temporary, file.bytes, file.path); !written) {
      discard_temporaries();
      return written;
    }
    temporaries.push_back(temporary);
  }
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (::rename(temporaries[i].c_str(), files[i].path.c_str()) != 0) {
      const int error_number = errno;
      discard_temporaries();  // files renamed before this one keep their new content
      return io_error(files[i].path, "write", error_number);
    }
  }
  return status::success();
}

status write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
  return write_files_atomically({{path, bytes}});
}

}  // namespace tracemesh::cli
