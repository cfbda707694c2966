#include "physics/recorder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>

namespace cansim::physics {

namespace {
constexpr std::size_t kMaxRow = 512;  // generous upper bound of one formatted row

char* put_double(char* p, char* end, double v) {
  auto r = std::to_chars(p, end, v);
  return r.ec == std::errc{} ? r.ptr : p;
}
template <class I>
char* put_int(char* p, char* end, I v) {
  auto r = std::to_chars(p, end, v);
  return r.ec == std::errc{} ? r.ptr : p;
}
bool refuse(std::string* error, const std::string& why) {
  if (error) *error = why;
  return false;
}

// True when `path` (symbolic links resolved, as far as it exists) lies in `dir`.
bool inside(const std::string& path, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path file = fs::weakly_canonical(fs::absolute(path, ec), ec);
  const fs::path root = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (file.empty() || root.empty()) return false;
  const fs::path rel = file.lexically_relative(root);
  return !rel.empty() && *rel.begin() != "..";
}
constexpr const char* kHardLinked = "a file with more than one name (hard links), which recordings never write to";
}  // namespace

const char* CsvRecorder::header() {
  return "time_s,true_pressure_pa,true_temperature_k,pressure_pa,temperature_k,pressure_status,"
         "temperature_status,pressure_counts,temperature_counts,pressure_flags,temperature_flags\n";
}

CsvRecorder::CsvRecorder(CsvRecorder&& o) noexcept
    : fd_(o.fd_), failed_(o.failed_), rows_(o.rows_), buf_(std::move(o.buf_)), cap_(o.cap_), len_(o.len_) {
  o.fd_ = -1;
  o.cap_ = o.len_ = 0;
}

CsvRecorder& CsvRecorder::operator=(CsvRecorder&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    failed_ = o.failed_;
    rows_ = o.rows_;
    buf_ = std::move(o.buf_);
    cap_ = o.cap_;
    len_ = o.len_;
    o.fd_ = -1;
    o.cap_ = o.len_ = 0;
  }
  return *this;
}

CsvRecorder::~CsvRecorder() { close(); }

bool CsvRecorder::open(const std::string& path, std::string* error, std::size_t buffer_bytes,
                       const std::string& refused_dir) {
  close();
  if (!refused_dir.empty() && inside(path, refused_dir))
    return refuse(error, path + ": in the state folder " + refused_dir + ", which recordings never write to");
  // A FIFO would block open() until a reader came, a device never end:
  // checked before, and (the path may change meanwhile) on what was opened.
  // A file with a second name may be a state file's hard link (the state
  // folder check sees only this name): truncating it would lose what a node stored.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) return refuse(error, path + ": not a regular file");
  if (st.st_nlink > 1) return refuse(error, path + ": " + kHardLinked);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_NONBLOCK | O_CLOEXEC | O_NOCTTY, 0644);
  if (fd < 0) return refuse(error, path + ": " + std::strerror(errno));
  const bool fstat_ok = ::fstat(fd, &st) == 0;
  const char* why = !fstat_ok || !S_ISREG(st.st_mode) ? "not a regular file" : st.st_nlink > 1 ? kHardLinked : nullptr;
  if (why || ::ftruncate(fd, 0) != 0) {
    const int err = errno;
    ::close(fd);
    return refuse(error, path + ": " + (why ? why : std::strerror(err)));
  }
  fd_ = fd;
  cap_ = buffer_bytes < 4096 ? 4096 : buffer_bytes;
  buf_ = std::make_unique<char[]>(cap_);
  len_ = 0;
  rows_ = 0;
  failed_ = false;
  const char* h = header();
  const std::size_t n = std::strlen(h);
  std::memcpy(buf_.get(), h, n);
  len_ = n;
  return flush();
}

void CsvRecorder::record(TimeUs t, const SensorReading& r) {
  if (fd_ < 0) return;
  if (cap_ - len_ < kMaxRow) flush();
  if (cap_ - len_ < kMaxRow) return;  // write failure: drop the row
  char* p = buf_.get() + len_;
  char* end = buf_.get() + cap_;
  // time in seconds with microsecond resolution, exactly: integer part . 6 digits
  const TimeUs sec = t >= 0 ? t / 1000000 : -((-t) / 1000000);
  const TimeUs frac = t >= 0 ? t % 1000000 : (-t) % 1000000;
  if (t < 0) *p++ = '-';
  p = put_int(p, end, sec < 0 ? -sec : sec);
  *p++ = '.';
  char digits[6];
  TimeUs f = frac;
  for (int i = 5; i >= 0; --i) {
    digits[i] = char('0' + f % 10);
    f /= 10;
  }
  std::memcpy(p, digits, 6);
  p += 6;
  *p++ = ',';
  p = put_double(p, end, r.pressure.truth);
  *p++ = ',';
  p = put_double(p, end, r.temperature.truth);
  *p++ = ',';
  p = put_double(p, end, r.pressure.value);
  *p++ = ',';
  p = put_double(p, end, r.temperature.value);
  *p++ = ',';
  p = put_int(p, end, unsigned(r.pressure.status));
  *p++ = ',';
  p = put_int(p, end, unsigned(r.temperature.status));
  *p++ = ',';
  p = put_int(p, end, r.pressure.adc_counts);
  *p++ = ',';
  p = put_int(p, end, r.temperature.adc_counts);
  *p++ = ',';
  p = put_int(p, end, unsigned(r.pressure.flags));
  *p++ = ',';
  p = put_int(p, end, unsigned(r.temperature.flags));
  *p++ = '\n';
  len_ = std::size_t(p - buf_.get());
  ++rows_;
}

bool CsvRecorder::flush() {
  if (fd_ < 0) return !failed_;
  std::size_t off = 0;
  while (off < len_) {
    const ssize_t w = ::write(fd_, buf_.get() + off, len_ - off);
    if (w < 0) {
      if (errno == EINTR) continue;
      failed_ = true;
      break;
    }
    off += std::size_t(w);
  }
  len_ = 0;
  return !failed_;
}

void CsvRecorder::close() {
  if (fd_ < 0) return;
  flush();
  ::close(fd_);
  fd_ = -1;
}

}  // namespace cansim::physics
