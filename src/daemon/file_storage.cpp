#include "daemon/file_storage.hpp"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "config/limits.hpp"
#include "core/can_frame.hpp"
#include "core/crc32.hpp"
#include "daemon/logging.hpp"

namespace cansim::daemon {

namespace {

constexpr std::uint8_t kMagic[4] = {'C', 'S', 'N', 'S'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeader = 16;

std::vector<std::uint8_t> read_all(int fd, std::size_t size) {
  std::vector<std::uint8_t> out(size);
  std::size_t got = 0;
  while (got < size) {
    const ssize_t n = ::read(fd, out.data() + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += std::size_t(n);
  }
  out.resize(got);
  return out;
}

bool write_all(int fd, const std::uint8_t* p, std::size_t n) {
  while (n > 0) {
    ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += w;
    n -= std::size_t(w);
  }
  return true;
}

}  // namespace

std::string FileStorage::file_name(const std::string& key) {
  std::string out;
  for (char c : key) {
    auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '-' || c == '_' || c == '.') out += c;
    else if (c == '/') out += '@';
    else {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", u);
      out += buf;
    }
  }
  return out + ".params";
}

FileStorage::FileStorage(std::string dir, const std::string& key)
    : key_(key), dir_(std::move(dir)), path_(dir_ + "/" + file_name(key)) {}

// What a state file must be to be read or written through: a regular file
// of the daemon's own with no other name ("" when it is), checked on the
// descriptor, after an open that neither followed a link nor waited.
const char* FileStorage::unfit(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return "cannot stat it";
  if (!S_ISREG(st.st_mode)) return "not a regular file";
  if (st.st_uid != ::geteuid()) return "not owned by cansimd's user";
  if (st.st_nlink > 1) return "a file with another name (a hard link)";
  if (std::size_t(st.st_size) > limits::kParameterFileBytes) return "larger than any cansimd parameter file";
  return nullptr;
}

// Read as the loop may: without blocking (O_NONBLOCK: a FIFO would wait for
// a writer, a device never end), never through a symbolic link (O_NOFOLLOW),
// a regular file of the daemon's own only, at most limits::kParameterFileBytes.
bool FileStorage::read_file() {
  cached_ = true;
  cache_.clear();
  error_.clear();
  ::unlink((path_ + ".tmp").c_str());  // a save a kill interrupted: the file itself is whole
  const int fd = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    if (errno == ENOENT) return reject("");
    return reject(errno == ELOOP ? "a symbolic link (state files are never followed)" : std::strerror(errno));
  }
  std::vector<std::uint8_t> raw;
  const char* why = unfit(fd);
  struct stat st {};
  if (!why && ::fstat(fd, &st) == 0) raw = read_all(fd, std::size_t(st.st_size));
  ::close(fd);
  if (why) return reject(why);
  if (raw.size() < kHeader || std::memcmp(raw.data(), kMagic, 4) != 0 || get_u32(raw.data() + 4) != kVersion ||
      get_u32(raw.data() + 8) != raw.size() - kHeader)
    return reject("not a cansimd parameter file");
  std::span<const std::uint8_t> blob(raw.data() + kHeader, raw.size() - kHeader);
  if (crc32(blob) != get_u32(raw.data() + 12)) return reject("CRC mismatch");
  cache_.assign(blob.begin(), blob.end());
  return true;
}

// Records why the file is not used ("" when there is none: not an error).
bool FileStorage::reject(const std::string& why) {
  if (!why.empty()) error_ = path_ + ": " + why + " (ignored: the node starts with its defaults)";
  return why.empty();
}

bool FileStorage::load(std::vector<std::uint8_t>& blob) {
  if (!cached_ && !read_file()) {
    const auto subject = LogSubject::node(key_);
    spdlog::warn("{}", error_);
  }
  blob = cache_;
  return !cache_.empty();
}

void FileStorage::rejected(const char* why) {
  if (rejected_) return;  // load() runs at every reset: once per stored blob
  rejected_ = true;
  const auto subject = LogSubject::node(key_);
  spdlog::warn("{}: {} (ignored: the node starts with its defaults)", path_, why);
}

bool FileStorage::save(std::span<const std::uint8_t> blob) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  std::vector<std::uint8_t> file(kHeader + blob.size());
  std::memcpy(file.data(), kMagic, 4);
  put_u32(file.data() + 4, kVersion);
  put_u32(file.data() + 8, std::uint32_t(blob.size()));
  put_u32(file.data() + 12, crc32(blob));
  if (!blob.empty()) std::memcpy(file.data() + kHeader, blob.data(), blob.size());

  // The temp file is always a new one (O_EXCL: whatever had its name, a
  // FIFO or a link, is gone or the save fails), opened without following or
  // waiting; the rename replaces `.params` itself, never what it points at.
  const std::string tmp = path_ + ".tmp";
  ::unlink(tmp.c_str());
  const int fd =
      ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY, 0644);
  int err = errno;
  const char* why = fd >= 0 ? unfit(fd) : nullptr;
  bool ok = fd >= 0 && !why && write_all(fd, file.data(), file.size()) && ::fsync(fd) == 0;
  if (fd >= 0 && !why && !ok) err = errno;
  if (fd >= 0) ::close(fd);
  if (ok && ::rename(tmp.c_str(), path_.c_str()) != 0) {
    ok = false;
    err = errno;
  }
  const auto subject = LogSubject::node(key_);
  if (!ok) {
    error_ = path_ + ": cannot store parameters: " + (why ? std::string(tmp + ": ") + why : std::strerror(err));
    spdlog::error("{}", error_);
    ::unlink(tmp.c_str());
    return false;
  }
  // The rename is durable only once the directory entry is.
  int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  cache_.assign(blob.begin(), blob.end());
  cached_ = true;
  rejected_ = false;
  spdlog::info("{}: parameters stored in {}", key_, path_);
  return true;
}

}  // namespace cansim::daemon
