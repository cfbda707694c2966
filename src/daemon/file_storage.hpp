// Stored parameters (0x1010, LSS store configuration) in one file per node
// under the state directory, named after the node's stable key (interface +
// config name + index: LSS may change the node-ID). Writes are atomic (temp
// file, fsync, rename, fsync of the directory): a kill at any moment leaves
// either the old or the new file (the `.tmp` such a kill leaves is removed at
// the next start). The blob is cached in memory because the core calls load()
// at every reset. Neither reading nor writing blocks the loop or goes through
// a link: `.params` and `.params.tmp` are opened O_NOFOLLOW | O_NONBLOCK, and
// used only as regular files owned by the daemon's user with one name
// (st_nlink 1), at most limits::kParameterFileBytes; the temp file is created
// afresh (O_EXCL) and renamed over `.params`. Anything else is ignored with a
// warning naming the file and why (a store fails, the old file stays).
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
  static const char* unfit(int fd);

  std::string key_;
  std::string dir_;
  std::string path_;
  std::string error_;
  std::vector<std::uint8_t> cache_;
  bool cached_ = false;
  bool rejected_ = false;  // the node dropped the cached blob (warned)
};

}  // namespace cansim::daemon
