#include <rtsim/workloads/files.h>
#include <rtsim/workloads/random.h>

#include <rtsim/workloads/error.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace rtsim {

void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write) {
  namespace fs = std::filesystem;
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
  }
  const uint64_t tag = mix64(uint64_t(::getpid()) ^
                             uint64_t(std::chrono::steady_clock::now().time_since_epoch().count()));
  fs::path temp = path;
  temp += ".tmp." + std::to_string(tag & 0xffffffff);
  try {
    {
      std::ofstream out(temp, std::ios::binary | std::ios::trunc);
      if (!out) throw std::runtime_error(path.string() + ": cannot open for writing");
      write(out);
      out.flush();
      if (!out) throw std::runtime_error(path.string() + ": write failed (disk full?)");
    }
    fs::rename(temp, path);
  } catch (...) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw;
  }
}

void write_file_atomic(const std::filesystem::path& path, const std::string& contents) {
  write_file_atomic(path, [&](std::ostream& out) { out.write(contents.data(), contents.size()); });
}

namespace {

std::string byte_count(uint64_t bytes) {
  if (bytes >= (uint64_t(1) << 30) && bytes % (uint64_t(1) << 30) == 0)
    return std::to_string(bytes >> 30) + " GiB";
  if (bytes >= (uint64_t(1) << 20) && bytes % (uint64_t(1) << 20) == 0)
    return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

// What stat says about a path a user gave, as an InputError when it is no
// regular file within the limit.
void require_regular_file(const std::filesystem::path& path, const struct stat& st,
                          uint64_t max_bytes) {
  if (S_ISDIR(st.st_mode)) throw InputError(path.string(), "is a folder, not a file");
  if (!S_ISREG(st.st_mode))
    throw InputError(path.string(), std::string("is not a regular file (") +
                                        (S_ISFIFO(st.st_mode)   ? "a FIFO"
                                         : S_ISCHR(st.st_mode)  ? "a character device"
                                         : S_ISBLK(st.st_mode)  ? "a block device"
                                         : S_ISSOCK(st.st_mode) ? "a socket"
                                                                : "not a file") +
                                        "); rtsim reads regular files only");
  if (uint64_t(st.st_size) > max_bytes)
    throw InputError(path.string(), "is " + std::to_string(uint64_t(st.st_size)) +
                                        " bytes, past the limit of " + byte_count(max_bytes) +
                                        " for this kind of file");
}

}  // namespace

uint64_t check_input_file(const std::filesystem::path& path, uint64_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path.string(), errno == ENOENT ? std::string("no such file")
                                                    : std::string("cannot read: ") + std::strerror(errno));
  require_regular_file(path, st, max_bytes);
  return uint64_t(st.st_size);
}

std::string read_input_file(const std::filesystem::path& path, uint64_t max_bytes) {
  check_input_file(path, max_bytes);
  // O_NONBLOCK: should the path turn into a FIFO between stat and open, open and
  // read return at once instead of waiting for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path.string(), std::string("cannot open: ") + std::strerror(errno));
  std::string bytes;
  try {
    struct stat st {};
    if (::fstat(fd, &st) != 0) throw InputError(path.string(), std::string("cannot read: ") + std::strerror(errno));
    require_regular_file(path, st, max_bytes);
    bytes.resize(size_t(st.st_size));
    size_t done = 0;
    for (;;) {
      if (done == bytes.size()) bytes.resize(bytes.size() + 65536);  // the file grew: read on, bounded
      const ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw InputError(path.string(), std::string("read failed: ") + std::strerror(errno));
      if (n == 0) break;
      done += size_t(n);
      if (done > max_bytes)
        throw InputError(path.string(), "grew past the limit of " + byte_count(max_bytes) + " while being read");
    }
    bytes.resize(done);
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return bytes;
}

uint64_t file_content_hash(const std::filesystem::path& path) {
  const std::string bytes = read_input_file(path, kMaxDataFileBytes);
  return hash_bytes(0x46494C45ull, bytes.data(), bytes.size());
}

bool path_exists(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}
bool is_file(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}
bool is_folder(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec);
}

}  // namespace rtsim
