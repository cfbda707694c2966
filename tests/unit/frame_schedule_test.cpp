// The bounded schedule of a replay's frames (io/frame_schedule.hpp): each
// released at its time, earliest first, equal times in the order given; a
// full schedule refuses more.
#include <gtest/gtest.h>

#include "io/frame_schedule.hpp"
#include "support/sim.hpp"

namespace cansim::io {
namespace {

using test::F;

TEST(FrameSchedule, ReleasesEachFrameAtItsTimeInOrder) {
  FrameSchedule s(4);
  EXPECT_EQ(s.next(), kNever);
  EXPECT_TRUE(s.push(300, F(0x3, {})));
  EXPECT_TRUE(s.push(100, F(0x1, {})));
  EXPECT_TRUE(s.push(300, F(0x4, {})));
  EXPECT_TRUE(s.push(200, F(0x2, {})));
  EXPECT_FALSE(s.push(50, F(0x5, {})));  // full
  EXPECT_EQ(s.room(), 0u);
  EXPECT_EQ(s.next(), 100);
  std::vector<std::uint32_t> out;
  s.release(99, [&](const CanFrame& f) { out.push_back(f.id); });
  EXPECT_TRUE(out.empty());
  s.release(200, [&](const CanFrame& f) { out.push_back(f.id); });
  EXPECT_EQ(out, (std::vector<std::uint32_t>{0x1, 0x2}));
  EXPECT_EQ(s.next(), 300);
  s.release(1000, [&](const CanFrame& f) { out.push_back(f.id); });
  EXPECT_EQ(out, (std::vector<std::uint32_t>{0x1, 0x2, 0x3, 0x4}));
  EXPECT_EQ(s.size(), 0u);
  EXPECT_EQ(s.next(), kNever);
}

}  // namespace
}  // namespace cansim::io
