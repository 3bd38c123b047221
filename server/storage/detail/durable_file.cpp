#include "server/storage/detail/durable_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "server/storage/content_hash.hpp"

namespace tracemesh::server::detail {

namespace fs = std::filesystem;

namespace {

std::atomic<std::uint64_t> temp_sequence{0};

status io_failure(std::string_view what, const fs::path& path, int error_number) {
  return status(errc::io_error, std::string(what) + " " + path.string() + ": " + std::strerror(error_number));
}

void append_u64(std::string& out, std::uint64_t value) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

std::uint64_t read_u64(const char* in) {
  std::uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value |= std::uint64_t{static_cast<unsigned char>(in[i])} << (8 * i);
  return value;
}

}  // namespace

int open_retrying(const char* path, int flags, unsigned mode) {
  int fd;
  do {
    fd = ::open(path, flags | O_CLOEXEC, mode);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

bool write_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t written = ::write(fd, bytes.data(), bytes.size());
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    bytes.remove_prefix(static_cast<std::size_t>(written));
  }
  return true;
}

bool fsync_directory(const fs::path& dir) {
  const int fd = open_retrying(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return false;
  const bool synced = ::fsync(fd) == 0;
  ::close(fd);
  return synced;
}

status write_file_durably(const fs::path& path, std::string_view bytes) {
  const fs::path temp = path.parent_path() / (std::string(durable_temp_prefix) + path.filename().string() + "-" +
                                              std::to_string(::getpid()) + "-" +
                                              std::to_string(temp_sequence.fetch_add(1)));
  const int fd = open_retrying(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0) return io_failure("cannot create", temp, errno);
  const auto abandon = [&](std::string_view what) {
    const int error_number = errno;
    ::close(fd);
    ::unlink(temp.c_str());
    return io_failure(what, temp, error_number);
  };
  if (!write_all(fd, bytes)) return abandon("cannot write");
  if (::fsync(fd) != 0) return abandon("cannot fsync");
  if (::close(fd) != 0) {
    const int error_number = errno;
    ::unlink(temp.c_str());
    return io_failure("cannot close", temp, error_number);
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int error_number = errno;
    ::unlink(temp.c_str());
    return io_failure("cannot rename", temp, error_number);
  }
  if (!fsync_directory(path.parent_path())) return io_failure("cannot fsync the directory of", path, errno);
  return status::success();
}

status remove_file_durably(const fs::path& path) {
  if (::unlink(path.c_str()) != 0) {
    if (errno == ENOENT) return status::success();
    return io_failure("cannot remove", path, errno);
  }
  if (!fsync_directory(path.parent_path())) return io_failure("cannot fsync the directory of", path, errno);
  return status::success();
}

std::optional<std::string> read_whole_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return std::move(bytes).str();
}

status ensure_writable_directory(const fs::path& dir, std::string_view what) {
  const std::string prefix = std::string(what) + " " + dir.string() + ": ";
  std::error_code error;
  if (fs::exists(dir, error) && !fs::is_directory(dir, error)) {
    return status(errc::io_error, prefix + "exists and is not a directory");
  }
  fs::create_directories(dir, error);
  if (error) return status(errc::io_error, prefix + "cannot be created (" + error.message() + ")");
  // Permission bits say nothing for root or on a read-only mount: write a probe file the way real writes go.
  const fs::path probe = dir / (std::string(durable_temp_prefix) + "probe");
  const status written = write_file_durably(probe, "probe");
  if (!written.ok()) return status(errc::io_error, prefix + "is not writable (" + written.message() + ")");
  ::unlink(probe.c_str());
  return status::success();
}

std::string seal(std::string_view magic8, std::string_view payload) {
  std::string out(magic8);
  append_u64(out, payload.size());
  sha256 hasher;
  hasher.update(payload);
  const sha256::digest checksum = hasher.finish();
  out.append(reinterpret_cast<const char*>(checksum.data()), checksum.size());
  out.append(payload);
  return out;
}

std::optional<std::string> unseal(std::string_view magic8, std::string_view sealed) {
  constexpr std::size_t header = 8 + 8 + sha256::digest_size;
  if (sealed.size() < header || sealed.substr(0, 8) != magic8) return std::nullopt;
  if (read_u64(sealed.data() + 8) != sealed.size() - header) return std::nullopt;
  const std::string_view payload = sealed.substr(header);
  sha256 hasher;
  hasher.update(payload);
  const sha256::digest checksum = hasher.finish();
  if (std::memcmp(checksum.data(), sealed.data() + 16, checksum.size()) != 0) return std::nullopt;
  return std::string(payload);
}

}  // namespace tracemesh::server::detail
