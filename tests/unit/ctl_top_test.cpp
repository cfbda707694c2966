// cansimctl top's table (src/ctl/top.hpp) from node properties as
// GetManagedObjects gives them: rows in natural order, filtered by a glob,
// frames per second from two samples; and the natural order itself.
#include <gtest/gtest.h>

#include <algorithm>

#include "ctl/top.hpp"
#include "ctl/values.hpp"

namespace cansim::ctl {
namespace {

NodeStatus node(std::string key, std::string name, std::uint8_t id) {
  NodeStatus s;
  s.key = std::move(key);
  s.name = std::move(name);
  s.node_id = id;
  s.nmt_state = "operational";
  s.powered = s.on_bus = true;
  s.pressure = {3.5, 3.456, "bar", 0x00};
  s.temperature = {22.5, 22.4, "degC", 0x02};
  return s;
}

TEST(CtlTop, RowsInNaturalOrderWithValuesUnitsAndState) {
  std::vector<NodeStatus> nodes = {node("vcan0/pt/10", "pt", 0x1A), node("vcan0/pt/2", "pt", 0x12),
                                   node("vcan0/dps/0", "dps", 0x7F)};
  nodes[2].temperature = {};
  nodes[2].on_bus = false;
  nodes[1].faults = {{1, "drift", true}, {2, "open", false}};
  nodes[1].emcy_count = 3;
  FrameRates none;
  std::vector<TopRow> rows;
  for (const NodeStatus& s : top_nodes(nodes, "")) rows.push_back(top_row(s, none));
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].key, "vcan0/dps/0");
  EXPECT_EQ(rows[1].key, "vcan0/pt/2");
  EXPECT_EQ(rows[2].key, "vcan0/pt/10");
  EXPECT_EQ(rows[0].state, "operational (off the bus)");
  EXPECT_EQ(rows[0].temperature, "-");
  EXPECT_EQ(rows[0].status, "00 --");
  EXPECT_EQ(rows[1].pressure, "3.456 / 3.5 bar");
  EXPECT_EQ(rows[1].temperature, "22.4 degC");
  EXPECT_EQ(rows[1].status, "00 02");
  EXPECT_EQ(rows[1].faults, "drift");
  EXPECT_EQ(rows[1].emcy, 3u);
  EXPECT_LT(rows[1].fps, 0) << "one sample: no rate yet";
  const std::string table = format_top_table(rows);
  EXPECT_EQ(table.substr(0, table.find('\n')),
            "KEY          ID    NMT                        PRESSURE (REPORTED / TRUE)  TEMPERATURE  STATUS  FAULTS  "
            "EMCY  FPS");
  EXPECT_NE(table.find("\nvcan0/pt/2   0x12  operational                3.456 / 3.5 bar             22.4 degC    "
                       "00 02   drift   3     -\n"),
            std::string::npos)
      << table;
}

TEST(CtlTop, GlobFiltersByKeyOrNameAndFramesPerSecondFromTwoSamples) {
  std::vector<NodeStatus> nodes = {node("vcan0/pt/0", "pt", 0x10), node("vcan0/pt/1", "pt", 0x11),
                                   node("vcan1/dps/0", "dps", 0x7F)};
  FrameRates rates;
  rates.sample("vcan0/pt/0", 100, 10.0);
  EXPECT_LT(rates.rate("vcan0/pt/0"), 0);
  rates.sample("vcan0/pt/0", 130, 10.5);
  EXPECT_DOUBLE_EQ(rates.rate("vcan0/pt/0"), 60.0);
  rates.sample("vcan0/pt/0", 5, 11.0);  // removed and added again: counting restarts
  EXPECT_LT(rates.rate("vcan0/pt/0"), 0);
  // A heartbeat a second sampled twice a second: 1.0 over the window, not 0 / 2.
  FrameRates heartbeat;
  for (int i = 0; i <= 20; ++i) heartbeat.sample("hb", std::uint64_t(i / 2), 0.5 * i);
  EXPECT_NEAR(heartbeat.rate("hb"), 1.0, 0.11);
  EXPECT_EQ(top_nodes(nodes, "pt/*").size(), 2u);
  EXPECT_EQ(top_nodes(nodes, "vcan1/*").size(), 1u);
  EXPECT_EQ(top_nodes(nodes, "dps").size(), 1u);
  EXPECT_EQ(top_nodes(nodes, "pt/1").at(0).key, "vcan0/pt/1");
  EXPECT_TRUE(top_nodes(nodes, "nothing*").empty());
  // A page of the table: header and rows [1, 2).
  std::vector<TopRow> rows;
  for (const NodeStatus& s : top_nodes(nodes, "")) rows.push_back(top_row(s, rates));
  const std::string page = format_top_table(rows, 1, 1);
  EXPECT_EQ(std::count(page.begin(), page.end(), '\n'), 2);
  EXPECT_NE(page.find("vcan0/pt/1"), std::string::npos) << page;
}

TEST(CtlTop, NaturalOrderComparesDigitRunsAsNumbers) {
  EXPECT_TRUE(natural_less("pt/2", "pt/10"));
  EXPECT_FALSE(natural_less("pt/10", "pt/2"));
  EXPECT_TRUE(natural_less("vcan0/a/9", "vcan1/a/0"));
  EXPECT_TRUE(natural_less("a", "a0"));
  EXPECT_TRUE(natural_less("generic-b/0", "generic/0") == (std::string("generic-b/0") < "generic/0"));
  EXPECT_FALSE(natural_less("x7", "x7"));
  EXPECT_TRUE(natural_less("x007", "x8"));
}

TEST(CtlTop, GlobMatchesKeysNamesAndNameIndex) {
  EXPECT_TRUE(glob_matches("pt/*", "vcan0/pt/3", "pt"));
  EXPECT_TRUE(glob_matches("vcan0/*", "vcan0/pt/3", "pt"));
  EXPECT_TRUE(glob_matches("p?", "vcan0/pt/3", "pt"));
  EXPECT_FALSE(glob_matches("dps*", "vcan0/pt/3", "pt"));
  EXPECT_TRUE(glob_matches("", "vcan0/pt/3", "pt"));
}

// More nodes than the terminal has rows: the title stays on the first line.
// The screen is drawn from the top-left corner; a newline after the last
// row would scroll the whole screen up by one and take the title away.
TEST(CtlTop, TheTitleStaysWhenTheFleetOutgrowsTheScreen) {
  std::vector<NodeStatus> nodes;
  for (int i = 0; i < 40; ++i) nodes.push_back(node("vcan0/pt/" + std::to_string(i), "pt", std::uint8_t(0x10 + i)));
  std::vector<TopRow> rows;
  FrameRates none;
  for (const NodeStatus& s : top_nodes(nodes, "")) rows.push_back(top_row(s, none));
  const std::size_t height = 24, page = height - 3;  // title, blank line, table header
  const std::string screen = top_screen("cansimctl top: 40 node(s)", format_top_table(rows, 0, page), height, 80);
  EXPECT_EQ(std::size_t(std::count(screen.begin(), screen.end(), '\n')), height - 1) << "one line per row, no scroll";
  EXPECT_TRUE(screen.starts_with("\x1b[Hcansimctl top: 40 node(s)\x1b[K\n")) << screen.substr(0, 60);
  EXPECT_TRUE(screen.ends_with("\x1b[K\x1b[J")) << "no newline after the last row";
  EXPECT_NE(screen.find("vcan0/pt/20"), std::string::npos);
  EXPECT_EQ(screen.find("vcan0/pt/21"), std::string::npos);
  // A table longer than the screen is cut, never scrolled.
  const std::string all = top_screen("title", format_top_table(rows), height, 80);
  EXPECT_EQ(std::size_t(std::count(all.begin(), all.end(), '\n')), height - 1);
  EXPECT_TRUE(all.starts_with("\x1b[Htitle\x1b[K\n"));
  // Lines are cut at the width.
  EXPECT_EQ(top_screen(std::string(100, 'x'), "", 5, 10), "\x1b[Hxxxxxxxxxx\x1b[K\n\x1b[K\x1b[J");
}

// Values read well at every magnitude; a device in counts says so, with
// what they mean (status's reading, PressureCounts).
TEST(CtlTop, CountsAndLargeValues) {
  NodeStatus smc = node("vcan0/smc/0", "smc", 0x20);
  smc.pressure = {2.5, 2.50175, "bar", 0x00, 10007.0};
  NodeStatus p92c = node("vcan0/p92c/0", "p92c", 0x01);
  p92c.pressure = {9990440.0, 9990440.0, "Pa", 0x00};
  FrameRates none;
  EXPECT_EQ(top_row(smc, none).pressure, "2.50175 / 2.5 bar (10 007 counts)");
  EXPECT_EQ(top_row(p92c, none).pressure, "9 990 440 / 9 990 440 Pa");
  const Json j = top_json(smc, none);
  EXPECT_EQ(j["node"], "vcan0/smc/0");
  EXPECT_EQ(j["pressure"]["counts"], 10007.0);
  EXPECT_EQ(j["pressure"]["unit"], "bar");
  EXPECT_EQ(j["frames_per_second"], nullptr);
  EXPECT_EQ(top_json(p92c, none)["pressure"]["counts"], nullptr);
}

}  // namespace
}  // namespace cansim::ctl
