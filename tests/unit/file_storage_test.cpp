#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "config/limits.hpp"
#include "daemon/file_storage.hpp"
#include "io/loop_core.hpp"
#include "support/captured_log.hpp"
#include "support/sim.hpp"

namespace cansim::daemon {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

class FileStorageTest : public ::testing::Test {
 protected:
  FileStorageTest() {
    char tmpl[] = "/tmp/cansim-fs-XXXXXX";
    dir = mkdtemp(tmpl);
  }
  ~FileStorageTest() override { fs::remove_all(dir); }
  std::string dir;
};

TEST_F(FileStorageTest, FileNameIsTheEscapedKey) {
  EXPECT_EQ(FileStorage::file_name("vcan0/dps/3"), "vcan0@dps@3.params");
  EXPECT_EQ(FileStorage::file_name("can 0/a:b/0"), "can%200@a%3Ab@0.params");
}

TEST_F(FileStorageTest, NothingStoredYet) {
  FileStorage s(dir, "vcan0/n/0");
  Bytes blob{9};
  EXPECT_FALSE(s.load(blob));
  EXPECT_TRUE(blob.empty());
}

TEST_F(FileStorageTest, SaveThenReloadInAFreshInstance) {
  Bytes data{1, 2, 3, 0xFF, 0};
  {
    FileStorage s(dir + "/sub", "vcan0/n/0");  // the directory is created
    ASSERT_TRUE(s.save(data));
    Bytes again;
    ASSERT_TRUE(s.load(again));
    EXPECT_EQ(again, data);
  }
  FileStorage fresh(dir + "/sub", "vcan0/n/0");
  Bytes got;
  ASSERT_TRUE(fresh.load(got));
  EXPECT_EQ(got, data);
  EXPECT_EQ(fs::file_size(fresh.path()), 16u + data.size());
  EXPECT_FALSE(fs::exists(fresh.path() + ".tmp")) << "temp file left behind";
  FileStorage other(dir + "/sub", "vcan0/n/1");
  EXPECT_FALSE(other.load(got));
}

TEST_F(FileStorageTest, LoadIsServedFromTheCache) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{7, 7}));
  fs::remove(s.path());
  Bytes got;
  ASSERT_TRUE(s.load(got));
  EXPECT_EQ(got, (Bytes{7, 7}));
}

TEST_F(FileStorageTest, CorruptFileIsIgnored) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{1, 2, 3, 4}));
  {
    std::fstream f(s.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(17);
    f.put(char(0x55));  // flip a payload byte: CRC mismatch
  }
  FileStorage fresh(dir, "k");
  Bytes got{1};
  EXPECT_FALSE(fresh.load(got));
  EXPECT_TRUE(got.empty());
  EXPECT_NE(fresh.error().find("CRC mismatch"), std::string::npos);
  std::ofstream(s.path(), std::ios::binary) << "garbage";
  FileStorage garbage(dir, "k");
  EXPECT_FALSE(garbage.load(got));
  EXPECT_NE(garbage.error().find("not a cansimd parameter file"), std::string::npos);
}

TEST_F(FileStorageTest, FailedSaveKeepsTheOldFileAndCache) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{1}));
  // Make the rename fail: the target becomes a non-empty directory.
  fs::remove(s.path());
  fs::create_directories(s.path() + "/x");
  EXPECT_FALSE(s.save(Bytes{2}));
  EXPECT_NE(s.error().find("cannot store parameters"), std::string::npos);
  EXPECT_FALSE(fs::exists(s.path() + ".tmp"));
  Bytes got;
  ASSERT_TRUE(s.load(got));
  EXPECT_EQ(got, (Bytes{1}));
}

// The whole chain: 0x1010 "save" of a changed 0x1017 lands in the file and a
// node rebuilt from the same key (daemon restart) boots with it.
TEST_F(FileStorageTest, StoredHeartbeatSurvivesARestart) {
  using test::F;
  auto profile = test::load_repo_profile("generic-404");
  NodeSetup setup = config::node_setup(profile);
  {
    io::LoopCore core;
    io::MemoryTransport tx(&core.now());
    io::BusId bus = core.add_bus("vcan0", tx, 3);
    io::NodeRef n = core.add_node(bus, setup, nullptr, std::make_unique<FileStorage>(dir, "vcan0/generic/0"));
    core.power_on(n, 0);
    core.receive(bus, F(0x610, {0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0}), 0);  // 500 ms
    core.receive(bus, F(0x610, {0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'}), 0);
    auto sent = tx.take();
    ASSERT_EQ(sent.size(), 3u);
    EXPECT_EQ(sent[2].frame, F(0x590, {0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0}));
  }
  io::LoopCore core;
  io::MemoryTransport tx(&core.now());
  io::BusId bus = core.add_bus("vcan0", tx, 3);
  io::NodeRef n = core.add_node(bus, setup, nullptr, std::make_unique<FileStorage>(dir, "vcan0/generic/0"));
  core.power_on(n, 0);
  EXPECT_EQ(core.node(n).values().u(0x1017, 0), 500u);
  core.run_until(ms(500));
  auto sent = tx.take();
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[1].time, ms(500));
  EXPECT_EQ(sent[1].frame, F(0x710, {0x7F}));
}

using test::CapturedLog;

// Reading happens on the daemon's loop: a FIFO in place of the file would
// hold it until a writer came (the alarm fails the test instead of hanging).
TEST_F(FileStorageTest, AFifoIsNotWaitedFor) {
  FileStorage s(dir, "k");
  ASSERT_EQ(::mkfifo(s.path().c_str(), 0600), 0);
  ::alarm(10);
  Bytes got{1};
  EXPECT_FALSE(s.load(got));
  ::alarm(0);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(s.error(), s.path() + ": not a regular file (ignored: the node starts with its defaults)");
}

// A link is never followed, not even into the state folder: reading it
// could run until out of memory (/dev/zero), storing through it would write
// wherever it points.
TEST_F(FileStorageTest, ASymbolicLinkIsNeverFollowed) {
  FileStorage s(dir, "k");
  fs::create_symlink("/dev/zero", s.path());
  Bytes got;
  ::alarm(10);
  EXPECT_FALSE(s.load(got));
  ::alarm(0);
  EXPECT_NE(s.error().find("a symbolic link (state files are never followed)"), std::string::npos) << s.error();
  fs::remove(s.path());
  FileStorage other(dir, "other");
  ASSERT_TRUE(other.save(Bytes{7, 8}));
  fs::create_symlink(other.path(), s.path());
  FileStorage linked(dir, "k");
  EXPECT_FALSE(linked.load(got));
  // A store replaces the link itself; the file it pointed at keeps its bytes.
  ASSERT_TRUE(linked.save(Bytes{1}));
  EXPECT_FALSE(fs::is_symlink(s.path()));
  FileStorage again(dir, "other");
  ASSERT_TRUE(again.load(got));
  EXPECT_EQ(got, (Bytes{7, 8}));
}

// What an outsider with write access to the state folder may put at the
// temp file's name between two stores: a FIFO held the loop (until a reader
// came), a link made the store write through it and left `.params` a link out
// of the folder. Both are replaced by a new regular file.
TEST_F(FileStorageTest, AFifoOrALinkAtTheTempFileNeitherBlocksNorRedirects) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{1}));
  const std::string tmp = s.path() + ".tmp";
  ASSERT_EQ(::mkfifo(tmp.c_str(), 0600), 0);
  ::alarm(10);
  ASSERT_TRUE(s.save(Bytes{2}));
  ::alarm(0);
  const std::string outside = dir + "/outside";
  std::ofstream(outside) << "keep";
  fs::create_symlink(outside, tmp);
  ASSERT_TRUE(s.save(Bytes{3}));
  EXPECT_FALSE(fs::is_symlink(s.path()));
  EXPECT_FALSE(fs::exists(tmp));
  std::ifstream in(outside);
  std::string text;
  in >> text;
  EXPECT_EQ(text, "keep");
  FileStorage fresh(dir, "k");
  Bytes got;
  ASSERT_TRUE(fresh.load(got));
  EXPECT_EQ(got, (Bytes{3}));
}

// A state file with a second name (a hard link made elsewhere) is not read:
// recordings refuse such files too, so neither can write into the other.
TEST_F(FileStorageTest, AHardLinkedStateFileIsRefused) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{4}));
  fs::create_hard_link(s.path(), dir + "/second-name");
  FileStorage fresh(dir, "k");
  Bytes got;
  EXPECT_FALSE(fresh.load(got));
  EXPECT_NE(fresh.error().find("a file with another name (a hard link)"), std::string::npos) << fresh.error();
}

// Stored parameters someone else owns are not the daemon's.
TEST_F(FileStorageTest, AFileOfAnotherUserIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a file away";
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{5}));
  ASSERT_EQ(::chown(s.path().c_str(), 65534, 65534), 0);
  FileStorage fresh(dir, "k");
  Bytes got;
  EXPECT_FALSE(fresh.load(got));
  EXPECT_NE(fresh.error().find("not owned by cansimd's user"), std::string::npos) << fresh.error();
}

TEST_F(FileStorageTest, AFileLargerThanTheBoundIsNotRead) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{1}));
  fs::resize_file(s.path(), limits::kParameterFileBytes + 1);
  FileStorage fresh(dir, "k");
  Bytes got;
  EXPECT_FALSE(fresh.load(got));
  EXPECT_NE(fresh.error().find("larger than any cansimd parameter file"), std::string::npos) << fresh.error();
}

// An unreadable file is reported with its path and the reason (it was a blank line).
TEST_F(FileStorageTest, AnUnreadableFileIsNamedWithTheReason) {
  std::ofstream(dir + "/file") << "not a folder";
  FileStorage s(dir + "/file", "k");
  CapturedLog log;
  Bytes got;
  EXPECT_FALSE(s.load(got));
  EXPECT_NE(log.text.str().find(dir + "/file/k.params: Not a directory (ignored: the node starts with its defaults)"),
            std::string::npos)
      << log.text.str();
}

// A kill between the temp file and the rename leaves `.params.tmp`: the next start removes it.
TEST_F(FileStorageTest, TheTempFileOfAnInterruptedSaveIsRemoved) {
  FileStorage s(dir, "k");
  ASSERT_TRUE(s.save(Bytes{3}));
  std::ofstream(s.path() + ".tmp") << "half";
  FileStorage fresh(dir, "k");
  Bytes got;
  ASSERT_TRUE(fresh.load(got));
  EXPECT_EQ(got, (Bytes{3}));
  EXPECT_FALSE(fs::exists(s.path() + ".tmp"));
}

// The node drops a blob (inner CRC, impossible node-ID): one warning per blob, though it loads at every reset.
TEST_F(FileStorageTest, ARejectedBlobIsLoggedOncePerBlob) {
  FileStorage s(dir, "k");
  CapturedLog log;
  s.rejected("stored parameters with a bad CRC");
  s.rejected("stored parameters with a bad CRC");
  ASSERT_TRUE(s.save(Bytes{1}));
  s.rejected("stored parameters with a bad CRC");
  const std::string text = log.text.str();
  const std::string line = s.path() + ": stored parameters with a bad CRC (ignored: the node starts with its defaults)";
  const auto first = text.find(line);
  ASSERT_NE(first, std::string::npos) << text;
  const auto second = text.find(line, first + 1);
  ASSERT_NE(second, std::string::npos) << text;
  EXPECT_EQ(text.find(line, second + 1), std::string::npos) << text;
}

}  // namespace
}  // namespace cansim::daemon
