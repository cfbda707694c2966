// Stored parameters (0x1010, LSS store configuration) in one file per node
// under the state directory, named after the node's stable key (interface +
// config name + index: LSS may change the node-ID). Writes are atomic (temp
// file, fsync, rename, fsync of the directory): a kill at any moment leaves
// either the old or the new file (the `.tmp` such a kill leaves is removed at
// the next start). The blob is cached in memory because the core calls load()
// at every reset. Reading never blocks the loop: a regular file only (a
// symbolic link only into the state folder), at most limits::kParameterFileBytes;
// anything else is ignored with a warning naming the file and why.
//
// File layout: "CSNS" u32 version=1, u32 length, u32 CRC-32 of the blob, blob.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/application.hpp"

namespace cansim::daemon {

class FileStorage : public NodeStorage {
 public:
  FileStorage(std::string dir, const std::string& key);

  bool load(std::vector<std::uint8_t>& blob) override;
  bool save(std::span<const std::uint8_t> blob) override;
  void rejected(const char* why) override;  // a warning, once per stored blob

  const std::string& path() const { return path_; }
  const std::string& error() const { return error_; }
  // "vcan0/dps/3" -> "vcan0@dps@3.params"; other unsafe characters as %XX.
  static std::string file_name(const std::string& key);

 private:
  bool read_file();
  bool reject(const std::string& why);
  bool link_stays_inside() const;

  std::string key_;
  std::string dir_;
  std::string path_;
  std::string error_;
  std::vector<std::uint8_t> cache_;
  bool cached_ = false;
  bool rejected_ = false;  // the node dropped the cached blob (warned)
};

std::uint32_t crc32(std::span<const std::uint8_t> data);

}  // namespace cansim::daemon
