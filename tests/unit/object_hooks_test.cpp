// The per-object indication table of a personality (personalities/object_hooks.hpp):
// lookup by index, areas with objects inside, a null handler falling back to
// the enclosing area, misses.
#include "personalities/object_hooks.hpp"

#include <gtest/gtest.h>

namespace cansim::test {
namespace {

using personalities::area;
using personalities::object;
using personalities::ObjectHook;
using personalities::ObjectHooks;

struct App {
  void read_a(Node&, const OdEntry&, TimeUs) {}
  void read_b(Node&, const OdEntry&, TimeUs) {}
  SdoAbort check_area(Node&, const OdEntry&, std::span<const std::uint8_t>, TimeUs) { return SdoAbort::kNone; }
  SdoAbort check_inner(Node&, const OdEntry&, std::span<const std::uint8_t>, TimeUs) { return SdoAbort::kNone; }
  void written_area(Node&, const OdEntry&, TimeUs) {}
  void written_last(Node&, const OdEntry&, TimeUs) {}

  static const ObjectHook<App> kRows[];
  static const ObjectHooks<App> kHooks;
};
using Row = ObjectHook<App>;

constexpr Row App::kRows[] = {
    object<App>(0x1002, &App::read_a),
    area<App>(0x2800, 0x2FFF, nullptr, &App::check_area, &App::written_area),
    object<App>(0x2803, &App::read_b, &App::check_inner),
    object<App>(0x2810, nullptr, nullptr),
    object<App>(0x2FFF, nullptr, nullptr, &App::written_last),
    area<App>(0x3130, 0x3131, &App::read_b),
    object<App>(0x9130, &App::read_a),
};
constexpr ObjectHooks<App> App::kHooks{kRows};

const Row* read(std::uint16_t i) { return App::kHooks.find(i, &Row::read); }
const Row* check(std::uint16_t i) { return App::kHooks.find(i, &Row::check); }
const Row* written(std::uint16_t i) { return App::kHooks.find(i, &Row::written); }

TEST(ObjectHooks, AnObjectsRowGivesItsHandlers) {
  ASSERT_NE(read(0x1002), nullptr);
  EXPECT_EQ(read(0x1002)->read, &App::read_a);
  EXPECT_EQ(read(0x9130)->read, &App::read_a);
  EXPECT_EQ(check(0x1002), nullptr);  // a handler the row leaves null is the chain's
  EXPECT_EQ(written(0x9130), nullptr);
}

TEST(ObjectHooks, IndicesWithoutARowAreTheChains) {
  for (std::uint16_t i : {0x0000, 0x1000, 0x1003, 0x27FF, 0x3000, 0x3132, 0x6130, 0x9131, 0xFFFF}) {
    EXPECT_EQ(read(i), nullptr) << std::hex << i;
    EXPECT_EQ(check(i), nullptr) << std::hex << i;
    EXPECT_EQ(written(i), nullptr) << std::hex << i;
  }
}

TEST(ObjectHooks, AnAreaCoversItsIndices) {
  for (std::uint16_t i : {0x3130, 0x3131}) EXPECT_EQ(read(i), &App::kRows[5]) << std::hex << i;
  for (std::uint16_t i : {0x2800, 0x2802, 0x2804, 0x280F, 0x2811, 0x2FFE}) {
    EXPECT_EQ(check(i), &App::kRows[1]) << std::hex << i;
    EXPECT_EQ(written(i), &App::kRows[1]) << std::hex << i;
    EXPECT_EQ(read(i), nullptr) << std::hex << i;
  }
}

TEST(ObjectHooks, AnObjectInsideAnAreaWinsAndFallsBackToItForWhatItLeavesNull) {
  EXPECT_EQ(read(0x2803), &App::kRows[2]);
  EXPECT_EQ(check(0x2803)->check, &App::check_inner);
  EXPECT_EQ(written(0x2803), &App::kRows[1]);  // the area's
  EXPECT_EQ(check(0x2810), &App::kRows[1]);    // a row of nulls: all the area's
  EXPECT_EQ(written(0x2810), &App::kRows[1]);
  EXPECT_EQ(written(0x2FFF)->written, &App::written_last);
  EXPECT_EQ(check(0x2FFF), &App::kRows[1]);
}

TEST(ObjectHooks, AnEmptyTableHasNothing) {
  constexpr ObjectHooks<App> none{};
  EXPECT_EQ(none.find(0x1002, &Row::read), nullptr);
}

}  // namespace
}  // namespace cansim::test
