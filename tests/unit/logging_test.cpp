#include <gtest/gtest.h>
#include <spdlog/details/null_mutex.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "daemon/file_storage.hpp"
#include "daemon/logging.hpp"

namespace cansim::daemon {
namespace {

using Fields = std::vector<std::string>;

// A burst per window, then held back and counted; the next window's first
// line (or the summary once the window closed) says how many.
TEST(Logging, LineBudgetHoldsBackAndCounts) {
  LineBudget budget(2, 10'000'000);
  EXPECT_TRUE(budget.allow(0));
  EXPECT_TRUE(budget.allow(1));
  EXPECT_FALSE(budget.allow(2));
  EXPECT_FALSE(budget.allow(9'999'999));
  EXPECT_FALSE(budget.summary_due(9'999'999));
  EXPECT_TRUE(budget.summary_due(10'000'000));
  EXPECT_TRUE(budget.allow(10'000'000));
  EXPECT_EQ(budget.take_held(), " (and 2 more such line(s) held back in the 10 s before)");
  EXPECT_EQ(budget.take_held(), "");
  EXPECT_FALSE(budget.summary_due(30'000'000));
}

TEST(Logging, LineWithoutSubject) {
  EXPECT_EQ(journal_fields(spdlog::level::info, "cansimd 0.1.0 starting"),
            (Fields{"MESSAGE=cansimd 0.1.0 starting", "PRIORITY=6", "SYSLOG_IDENTIFIER=cansimd"}));
}

TEST(Logging, PrioritiesAreSyslogs) {
  auto priority = [](spdlog::level::level_enum l) { return journal_fields(l, "x")[1]; };
  EXPECT_EQ(priority(spdlog::level::trace), "PRIORITY=7");
  EXPECT_EQ(priority(spdlog::level::debug), "PRIORITY=7");
  EXPECT_EQ(priority(spdlog::level::info), "PRIORITY=6");
  EXPECT_EQ(priority(spdlog::level::warn), "PRIORITY=4");
  EXPECT_EQ(priority(spdlog::level::err), "PRIORITY=3");
  EXPECT_EQ(priority(spdlog::level::critical), "PRIORITY=2");
}

TEST(Logging, InterfaceSubject) {
  const auto subject = LogSubject::interface("can1");
  EXPECT_EQ(journal_fields(spdlog::level::warn, "can1: down"),
            (Fields{"MESSAGE=can1: down", "PRIORITY=4", "SYSLOG_IDENTIFIER=cansimd", "CANSIM_IFACE=can1"}));
}

TEST(Logging, NodeSubjectNamesItsInterfaceToo) {
  const auto subject = LogSubject::node("vcan0/dps/0");
  Fields f = journal_fields(spdlog::level::info, "stored");
  ASSERT_EQ(f.size(), 5u);
  EXPECT_EQ(f[3], "CANSIM_IFACE=vcan0");
  EXPECT_EQ(f[4], "CANSIM_NODE=vcan0/dps/0");
}

TEST(Logging, InnerSubjectReplacesTheOuterUntilItEnds) {
  {
    const auto outer = LogSubject::interface("vcan1");
    {
      const auto inner = LogSubject::node("vcan0/generic/2");
      EXPECT_EQ(LogSubject::current_interface(), "vcan0");
      EXPECT_EQ(LogSubject::current_node(), "vcan0/generic/2");
    }
    EXPECT_EQ(LogSubject::current_interface(), "vcan1");
    EXPECT_EQ(LogSubject::current_node(), "");
  }
  EXPECT_EQ(LogSubject::current_interface(), "");
  EXPECT_EQ(journal_fields(spdlog::level::info, "x").size(), 3u);
}

TEST(Logging, MessageKeepsNewlinesAndEquals) {
  EXPECT_EQ(journal_fields(spdlog::level::err, "a=b\nc")[0], "MESSAGE=a=b\nc");
}

TEST(Logging, JournalStreamMustNameStderr) {
  EXPECT_TRUE(journal_stream_matches("8:1234567", 8, 1234567));
  EXPECT_FALSE(journal_stream_matches("8:1234567", 8, 1234568));
  EXPECT_FALSE(journal_stream_matches("9:1234567", 8, 1234567));
  EXPECT_FALSE(journal_stream_matches(nullptr, 8, 1234567));
  EXPECT_FALSE(journal_stream_matches("", 8, 1234567));
  EXPECT_FALSE(journal_stream_matches("8:1234567x", 8, 1234567));
  EXPECT_FALSE(journal_stream_matches("8", 8, 0));
}

// Keeps the journal entry each line would have been.
class FieldsSink : public spdlog::sinks::base_sink<spdlog::details::null_mutex> {
 public:
  std::vector<Fields> lines;

 protected:
  void sink_it_(const spdlog::details::log_msg& m) override {
    lines.push_back(journal_fields(m.level, std::string_view(m.payload.data(), m.payload.size())));
  }
  void flush_() override {}
};

TEST(Logging, StoredParametersAreLoggedAsTheNodes) {
  char tmpl[] = "/tmp/cansim-log-XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  auto sink = std::make_shared<FieldsSink>();
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("test", sink));
  const std::uint8_t blob[] = {1, 2, 3};
  EXPECT_TRUE(FileStorage(dir, "vcan0/dps/0").save(blob));
  std::fclose(std::fopen((dir + "/file").c_str(), "w"));
  EXPECT_FALSE(FileStorage(dir + "/file", "can1/p92c/2").save(blob));  // its folder is a file
  spdlog::set_default_logger(previous);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(sink->lines.size(), 2u);
  EXPECT_EQ(sink->lines[0],
            (Fields{"MESSAGE=vcan0/dps/0: parameters stored in " + dir + "/vcan0@dps@0.params", "PRIORITY=6",
                    "SYSLOG_IDENTIFIER=cansimd", "CANSIM_IFACE=vcan0", "CANSIM_NODE=vcan0/dps/0"}));
  EXPECT_EQ(sink->lines[1][1], "PRIORITY=3");
  EXPECT_EQ(sink->lines[1][3], "CANSIM_IFACE=can1");
  EXPECT_EQ(sink->lines[1][4], "CANSIM_NODE=can1/p92c/2");
}

}  // namespace
}  // namespace cansim::daemon
