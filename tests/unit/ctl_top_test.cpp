// cansimctl top's table (src/ctl/top.hpp) from node properties as
// GetManagedObjects gives them: rows in natural order, filtered by a glob,
// frames per second from two samples; and the natural order itself.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace cansim::ctl
