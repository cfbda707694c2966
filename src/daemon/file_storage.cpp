#include "daemon/file_storage.hpp"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "config/limits.hpp"
#include "core/can_frame.hpp"
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

std::uint32_t crc32(std::span<const std::uint8_t> data) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::uint8_t b : data) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

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

// Read as the loop may: without blocking (O_NONBLOCK, a regular file only:
// a FIFO would wait for a writer, a device never end), at most
// limits::kParameterFileBytes, and a symbolic link only into the state folder.
bool FileStorage::read_file() {
  cached_ = true;
  cache_.clear();
  error_.clear();
  ::unlink((path_ + ".tmp").c_str());  // a save a kill interrupted: the file itself is whole
  struct stat st{};
  if (::lstat(path_.c_str(), &st) != 0) return reject(errno == ENOENT ? "" : std::strerror(errno));
  if (S_ISLNK(st.st_mode) && !link_stays_inside()) return reject("a symbolic link out of the state folder");
  const int fd = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return reject(std::strerror(errno));
  std::vector<std::uint8_t> raw;
  const char* why = nullptr;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) why = "not a regular file";
  else if (std::size_t(st.st_size) > limits::kParameterFileBytes) why = "larger than any cansimd parameter file";
  else raw = read_all(fd, std::size_t(st.st_size));
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

bool FileStorage::link_stays_inside() const {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path target = fs::canonical(path_, ec);
  const fs::path dir = fs::canonical(dir_, ec);
  if (target.empty() || dir.empty()) return false;
  const fs::path rel = target.lexically_relative(dir);
  return !rel.empty() && *rel.begin() != "..";
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

  std::string tmp = path_ + ".tmp";
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  bool ok = fd >= 0 && write_all(fd, file.data(), file.size()) && ::fsync(fd) == 0;
  int err = errno;
  if (fd >= 0) ::close(fd);
  if (ok && ::rename(tmp.c_str(), path_.c_str()) != 0) {
    ok = false;
    err = errno;
  }
  const auto subject = LogSubject::node(key_);
  if (!ok) {
    error_ = path_ + ": cannot store parameters: " + std::strerror(err);
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
