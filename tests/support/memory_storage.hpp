// The node storage of every test and fuzzer: what 0x1010 / LSS store saved,
// kept in memory. A test can make saves fail, count them and read what the
// node said when it dropped the stored blob (an owner's log line).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/application.hpp"

namespace cansim::test {

class MemoryStorage : public NodeStorage {
 public:
  bool load(std::vector<std::uint8_t>& blob) override {
    blob = data;
    return !data.empty();
  }
  bool save(std::span<const std::uint8_t> blob) override {
    if (fail_saves) return false;
    data.assign(blob.begin(), blob.end());
    ++saves;
    return true;
  }
  void rejected(const char* why) override { rejections.emplace_back(why); }

  std::vector<std::uint8_t> data;
  int saves = 0;
  bool fail_saves = false;
  std::vector<std::string> rejections;  // what the node said when it dropped `data`
};

}  // namespace cansim::test
