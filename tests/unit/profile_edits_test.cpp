// Every shipped profile, edited as users edit profiles: each line of its
// `objects:` list deleted in turn, and each such line's type changed in turn.
// Either the loader (parse + prepare, what --check runs) rejects the edit
// with file:line: and a key, or the node survives a session: power-on, NMT
// start, an SDO upload of every object, SYNCs, PDOs, a store, NMT reset and
// operation again. The asan tier runs this under ASan/UBSan: a dereference of
// a missing object fails there even where it happens not to crash here.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "config/profile.hpp"
#include "personalities/registry.hpp"
#include "support/sim.hpp"

namespace cansim {
namespace {

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

// A type of another size or kind, as a user mistypes it.
std::string other_type(const std::string& type) {
  if (type == "UNSIGNED8") return "UNSIGNED32";
  if (type == "UNSIGNED16") return "INTEGER8";
  if (type == "UNSIGNED32") return "UNSIGNED16";
  if (type == "INTEGER16") return "REAL32";
  if (type == "INTEGER32") return "UNSIGNED8";
  if (type == "REAL32") return "INTEGER16";
  return "UNSIGNED8";
}

struct Outcome {
  bool rejected = false;
  std::string message;
};

// The session a master would run against the node; must not crash.
void run_session(const config::Profile& profile) {
  personalities::NodeContext ctx;
  ctx.key = "vcan0/edited";
  std::unique_ptr<Application> app = personalities::make_application(profile, ctx);
  test::SimBus bus;
  const std::uint8_t id = profile.node_id == 0xFF ? 5 : profile.node_id;
  bus.add(profile, id, app.get());
  bus.power_on_all();
  bus.run_for(20'000);
  bus.inject(CanFrame::make(0x000, {0x01, 0x00}));  // NMT start all
  bus.run_for(30'000);
  for (const OdEntry& e : profile.layout->entries()) {
    bus.inject(
        CanFrame::make(0x600u + id, {0x40, std::uint8_t(e.index), std::uint8_t(e.index >> 8), e.sub, 0, 0, 0, 0}));
    bus.inject(CanFrame::make(0x080, {}));  // SYNC
    bus.run_for(1'000);
    bus.take();
  }
  // Store all (0x1010:01 "save"), reset node, start again.
  bus.inject(CanFrame::make(0x600u + id, {0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'}));
  bus.run_for(10'000);
  bus.inject(CanFrame::make(0x000, {0x81, 0x00}));
  bus.run_for(20'000);
  bus.inject(CanFrame::make(0x000, {0x01, 0x00}));
  bus.run_for(100'000);
}

Outcome try_edit(const std::string& text, const std::string& file) {
  config::Profile profile;
  try {
    profile = config::parse_profile(text, file);
  } catch (const config::ConfigError& e) {
    return {true, e.what()};
  }
  run_session(profile);
  return {};
}

class ProfileEdits : public ::testing::TestWithParam<const char*> {
 protected:
  void check(const std::string& what, const std::vector<std::string>& edited) {
    const std::string file = std::string(GetParam()) + ".yaml";
    SCOPED_TRACE(what);
    Outcome o = try_edit(join(edited), file);
    if (!o.rejected) {
      ++ran;
      return;
    }
    ++rejected;
    // "dps.yaml:12:5: objects: ..." : the file, a line and a key.
    static const std::regex where(R"(^[a-z0-9-]+\.yaml:[1-9][0-9]*(:[0-9]+)?: [^ ].*)");
    EXPECT_TRUE(std::regex_match(o.message, where)) << o.message;
  }
  int ran = 0, rejected = 0;
};

TEST_P(ProfileEdits, EachObjectDeletedOrRetypedIsRejectedOrRuns) {
  const std::vector<std::string> lines = lines_of(std::string(CANSIM_SOURCE_DIR) + "/profiles/" + GetParam() + ".yaml");
  static const std::regex object_line(R"(^\s*- \{index: .*)");
  static const std::regex type_field(R"(type: ([A-Z_0-9]+))");
  // Under ASan/UBSan (the asan tier, one core beside the VM tiers) every
  // third object line: the plain build edits them all, and profile_fuzz
  // mutates profiles under the sanitizers as well.
#ifdef CANSIM_SANITIZED
  constexpr int kStride = 3;
#else
  constexpr int kStride = 1;
#endif
  int objects = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (!std::regex_match(lines[i], object_line)) continue;
    if (objects++ % kStride != 0) continue;
    std::vector<std::string> edited = lines;
    edited.erase(edited.begin() + std::ptrdiff_t(i));
    check("deleted line " + std::to_string(i + 1) + ": " + lines[i], edited);

    std::smatch m;
    if (!std::regex_search(lines[i], m, type_field)) continue;
    edited = lines;
    edited[i] = m.prefix().str() + "type: " + other_type(m[1].str()) + m.suffix().str();
    check("retyped line " + std::to_string(i + 1) + ": " + edited[i], edited);
  }
  EXPECT_GT(objects, 20);
  std::printf("%s: %d object lines; %d edits rejected by the loader, %d ran a session\n", GetParam(), objects, rejected,
              ran);
}

INSTANTIATE_TEST_SUITE_P(Shipped, ProfileEdits,
                         ::testing::Values("generic-404", "dps", "p92c", "gems9000", "smc", "cmp"),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

}  // namespace
}  // namespace cansim
