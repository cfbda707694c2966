// Optional CSV recorder of one node's truth and readings (for plots: scripts/plot-recording).
//
// Columns (header line written by open()):
//   time_s              read time (simulated seconds)
//   true_pressure_pa    process pressure at the latest sample
//   true_temperature_k  process temperature at the latest sample
//   pressure_pa         reported pressure (after the whole chain)
//   temperature_k       reported temperature
//   pressure_status     CiA 404 status bits (1 invalid, 2 positive overload, 4 negative overload)
//   temperature_status
//   pressure_counts     raw ADC code of the latest sample
//   temperature_counts
//   pressure_flags      physics kFlag* bits (damaged, saturated, stuck, fault, open, short)
//   temperature_flags
//
// The row buffer is allocated by open(); record() formats with std::to_chars into it and
// writes whole buffers with write(2): no allocation per row.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "physics/sensor.hpp"
#include "physics/time.hpp"

namespace cansim::physics {

class CsvRecorder {
 public:
  static constexpr std::size_t kDefaultBuffer = 64 * 1024;

  CsvRecorder() = default;
  CsvRecorder(const CsvRecorder&) = delete;
  CsvRecorder& operator=(const CsvRecorder&) = delete;
  CsvRecorder(CsvRecorder&& o) noexcept;
  CsvRecorder& operator=(CsvRecorder&& o) noexcept;
  ~CsvRecorder();

  // Creates / truncates `path` and writes the header. buffer_bytes >= 4096.
  // Only a regular file, opened without blocking (a FIFO would hold the
  // caller until a reader came, a device never end), and never one inside
  // `refused_dir` (the daemon's state folder; symbolic links resolved).
  bool open(const std::string& path, std::string* error = nullptr, std::size_t buffer_bytes = kDefaultBuffer,
            const std::string& refused_dir = {});
  // Appends one row. No-op when not open.
  void record(TimeUs t, const SensorReading& r);
  // Writes buffered rows to the file. Returns false after a write error.
  bool flush();
  // flush() and close the file.
  void close();

  bool is_open() const { return fd_ >= 0; }
  bool failed() const { return failed_; }
  std::uint64_t rows() const { return rows_; }

  static const char* header();

 private:
  int fd_ = -1;
  bool failed_ = false;
  std::uint64_t rows_ = 0;
  std::unique_ptr<char[]> buf_;
  std::size_t cap_ = 0;
  std::size_t len_ = 0;
};

}  // namespace cansim::physics
