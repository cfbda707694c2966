// SDO block download and upload (CiA 301 §7.2.4.3.9-16): sub-blocks, ackseq,
// resend, CRC, pst fallback, block size and sequence aborts, timeouts.
#include "core/crc16.hpp"
#include "sdo_support.hpp"

namespace cansim::test {
namespace {

using SdoBlockTest = SdoFixture;

std::vector<std::uint8_t> pattern(std::size_t n) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = std::uint8_t(i * 7 + 3);
  return v;
}
std::uint8_t lo(std::uint32_t v) { return std::uint8_t(v); }
std::uint8_t hi(std::uint32_t v) { return std::uint8_t(v >> 8); }

TEST(Crc16Ccitt, CiaTestVector) {
  const char* s = "123456789";
  EXPECT_EQ(crc16_ccitt({reinterpret_cast<const std::uint8_t*>(s), 9}), 0x31C3);
  EXPECT_EQ(crc16_ccitt({}), 0x0000);
  // Running CRC over two parts equals the CRC of the whole.
  std::uint16_t part = crc16_ccitt({reinterpret_cast<const std::uint8_t*>(s), 4});
  EXPECT_EQ(crc16_ccitt({reinterpret_cast<const std::uint8_t*>(s) + 4, 5}, part), 0x31C3);
}

// ------------------------------------------------------------ block download

class SdoBlockDownload : public SdoBlockTest {
 protected:
  // Client segment `seq` with data from `pos`.
  CanFrame seg(std::uint8_t seq, std::size_t pos, bool last = false) {
    return block_segment(kSdoRx, seq, data, pos, last);
  }
  std::vector<CanFrame> end(std::uint8_t unused, std::uint16_t crc) {
    return req({std::uint8_t(0xC1 | (unused << 2)), lo(crc), hi(crc), 0, 0, 0, 0, 0});
  }
  std::vector<CanFrame> initiate(std::uint32_t size, bool crc = true) {
    std::uint8_t cs = std::uint8_t(0xC2 | (crc ? 0x04 : 0));
    return req({cs, 0x01, 0x20, 0x00, std::uint8_t(size), std::uint8_t(size >> 8), 0, 0});
  }
  std::uint16_t crc() { return crc16_ccitt(data); }
  std::vector<std::uint8_t> data = pattern(20);
  const std::vector<CanFrame> kInitOk = one({0xA4, 0x01, 0x20, 0x00, 127, 0, 0, 0});
  const std::vector<CanFrame> kDone = one({0xA1, 0, 0, 0, 0, 0, 0, 0});
};

TEST_F(SdoBlockDownload, ThreeSegmentsWithCrc) {
  EXPECT_EQ(initiate(20), kInitOk);
  EXPECT_TRUE(req(seg(1, 0)).empty());
  EXPECT_TRUE(req(seg(2, 7)).empty());
  EXPECT_EQ(req(seg(3, 14, true)), one({0xA2, 3, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0).size(), 16u);  // written only after the end frame
  EXPECT_EQ(end(1, crc()), kDone);          // 20 = 2 * 7 + 6: one unused byte
  EXPECT_EQ(value(0x2001, 0), data);
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoBlockDownload, ClientWithoutCrcIsNotChecked) {
  EXPECT_EQ(initiate(20, false), kInitOk);
  req(seg(1, 0));
  req(seg(2, 7));
  EXPECT_EQ(req(seg(3, 14, true)), one({0xA2, 3, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(1, 0x0000), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, WithoutSizeIndication) {
  EXPECT_EQ(req({0xC4, 0x01, 0x20, 0x00, 0, 0, 0, 0}), kInitOk);
  req(seg(1, 0));
  req(seg(2, 7));
  req(seg(3, 14, true));
  EXPECT_EQ(end(1, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, LostSegmentBreaksSubBlockAndIsResent) {
  data = pattern(35);  // five full segments
  initiate(35);
  req(seg(1, 0));
  EXPECT_EQ(req(seg(3, 14)), one({0xA2, 1, 127, 0, 0, 0, 0, 0}));  // 2 lost: ack 1
  // Frames the client sent before it saw the ack: before the new sequence.
  EXPECT_TRUE(req(seg(4, 21)).empty());
  EXPECT_TRUE(req(seg(5, 28, true)).empty());
  // Resend from the data after ackseq, numbered from 1 again.
  EXPECT_TRUE(req(seg(1, 7)).empty());
  EXPECT_TRUE(req(seg(2, 14)).empty());
  EXPECT_TRUE(req(seg(3, 21)).empty());
  EXPECT_EQ(req(seg(4, 28, true)), one({0xA2, 4, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(0, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, DuplicatesAreIgnored) {
  initiate(20);
  req(seg(1, 0));
  EXPECT_TRUE(req(seg(1, 0)).empty());
  req(seg(2, 7));
  EXPECT_TRUE(req(seg(2, 7)).empty());
  EXPECT_EQ(req(seg(3, 14, true)), one({0xA2, 3, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(1, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, ReorderedSegmentsBreakAndResume) {
  initiate(20);
  req(seg(1, 0));
  EXPECT_EQ(req(seg(3, 14, true)), one({0xA2, 1, 127, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(req(seg(2, 7)).empty());  // late: before the new sequence
  EXPECT_TRUE(req(seg(1, 7)).empty());
  EXPECT_EQ(req(seg(2, 14, true)), one({0xA2, 2, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(1, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, SeveralSubBlocks) {
  data = pattern(899);  // 128 full segments + 3 bytes = 127 + 2 segments
  initiate(899);
  for (int s = 1; s < 127; ++s) ASSERT_TRUE(req(seg(std::uint8_t(s), std::size_t(s - 1) * 7)).empty());
  EXPECT_EQ(req(seg(127, 126 * 7)), one({0xA2, 127, 127, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(req(seg(1, 127 * 7)).empty());
  EXPECT_EQ(req(seg(2, 128 * 7, true)), one({0xA2, 2, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(4, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

TEST_F(SdoBlockDownload, BadCrcAborts) {
  initiate(20);
  req(seg(1, 0));
  req(seg(2, 7));
  req(seg(3, 14, true));
  EXPECT_EQ(end(1, std::uint16_t(crc() ^ 0x0100)), aborted(0x2001, 0, SdoAbort::kCrc));
  EXPECT_EQ(value(0x2001, 0).size(), 16u);  // unchanged default
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoBlockDownload, SequenceNumberZeroAborts) {
  initiate(20);
  req(seg(1, 0));
  EXPECT_EQ(req(F(kSdoRx, {0x00, 1, 2, 3, 4, 5, 6, 7})), aborted(0x2001, 0, SdoAbort::kSequenceNumber));
}

TEST_F(SdoBlockDownload, ClientAbortInSubBlockIsSilent) {
  initiate(20);
  req(seg(1, 0));
  EXPECT_TRUE(req({0x80, 0x01, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05}).empty());
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoBlockDownload, SizeErrors) {
  EXPECT_EQ(initiate(4097), aborted(0x2001, 0, SdoAbort::kLengthTooHigh));
  // Less data than indicated.
  initiate(20);
  req(seg(1, 0));
  EXPECT_EQ(req(seg(2, 7, true)), one({0xA2, 2, 127, 0, 0, 0, 0, 0}));
  data.resize(14);
  EXPECT_EQ(end(0, crc()), aborted(0x2001, 0, SdoAbort::kLengthTooLow));
  // More data than indicated.
  data = pattern(20);
  initiate(6);
  EXPECT_TRUE(req(seg(1, 0)).empty());
  EXPECT_EQ(req(seg(2, 7)), aborted(0x2001, 0, SdoAbort::kLengthTooHigh));
  // Block download to read-only and missing objects.
  EXPECT_EQ(req({0xC6, 0x08, 0x10, 0x00, 1, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kReadOnly));
  EXPECT_EQ(req({0xC6, 0x34, 0x12, 0x00, 1, 0, 0, 0}), aborted(0x1234, 0, SdoAbort::kNoObject));
}

TEST_F(SdoBlockDownload, FixedSizeObject) {
  data = {0xD0, 0x07};
  EXPECT_EQ(req({0xC6, 0x17, 0x10, 0x00, 2, 0, 0, 0}), one({0xA4, 0x17, 0x10, 0x00, 127, 0, 0, 0}));
  EXPECT_EQ(req(seg(1, 0, true)), one({0xA2, 1, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(5, crc()), kDone);
  EXPECT_EQ(node().values().u(0x1017, 0), 2000u);
  EXPECT_EQ(req({0xC6, 0x17, 0x10, 0x00, 3, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kLengthTooHigh));
}

TEST_F(SdoBlockDownload, WrongEndCommandAborts) {
  initiate(20);
  req(seg(1, 0));
  req(seg(2, 7));
  req(seg(3, 14, true));
  EXPECT_EQ(req({0xA1, 0, 0, 0, 0, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  initiate(20);
  req(seg(1, 0));
  req(seg(2, 7));
  req(seg(3, 14, true));
  EXPECT_EQ(end(7, crc()), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
}

// Segments stop: after 70 % of the SDO timeout the server acknowledges the
// last good one (the client resends from there); then the timeout aborts.
TEST_F(SdoBlockDownload, StalledSubBlockIsAcknowledgedThenTimesOut) {
  bus_.run_until(ms(50));
  initiate(20);
  bus_.run_until(ms(550));
  req(seg(1, 0));
  bus_.run_until(ms(1250) - 1);
  EXPECT_TRUE(replies().empty());
  bus_.run_until(ms(3000));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].time, ms(1250));
  EXPECT_EQ(got[0].frame, F(kSdoTx, {0xA2, 1, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(got[1].time, ms(1550));
  EXPECT_EQ(got[1].frame, abort_frame(0x2001, 0, 0x05040000));
}

// The first segment of a sub-block is lost: nothing in sequence arrives, the
// stall acknowledge with ackseq 0 makes the client resend the whole sub-block.
TEST_F(SdoBlockDownload, LostFirstSegmentIsRecoveredByTheStallAcknowledge) {
  bus_.run_until(ms(50));
  initiate(20);
  EXPECT_TRUE(req(seg(2, 7)).empty());
  EXPECT_TRUE(req(seg(3, 14, true)).empty());
  bus_.run_until(ms(50) + ms(700));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].frame, F(kSdoTx, {0xA2, 0, 127, 0, 0, 0, 0, 0}));
  req(seg(1, 0));
  req(seg(2, 7));
  EXPECT_EQ(req(seg(3, 14, true)), one({0xA2, 3, 127, 0, 0, 0, 0, 0}));
  EXPECT_EQ(end(1, crc()), kDone);
  EXPECT_EQ(value(0x2001, 0), data);
}

// ------------------------------------------------------------ block upload

class SdoBlockUpload : public SdoBlockTest {
 protected:
  void SetUp() override {
    SdoBlockTest::SetUp();
    data = pattern(100);
    set_value(0x2001, 0, data);
  }
  CanFrame seg(std::uint8_t seq, std::size_t pos, bool last = false) {
    return block_segment(kSdoTx, seq, data, pos, last);
  }
  std::vector<CanFrame> segs(std::uint8_t first_seq, std::size_t pos, int count, bool last_at_end) {
    std::vector<CanFrame> out;
    for (int i = 0; i < count; ++i)
      out.push_back(seg(std::uint8_t(first_seq + i), pos + std::size_t(i) * 7, last_at_end && i == count - 1));
    return out;
  }
  std::vector<CanFrame> initiate(std::uint8_t blksize, std::uint8_t pst = 0, bool crc = true,
                                 std::uint16_t index = 0x2001) {
    return req({std::uint8_t(crc ? 0xA4 : 0xA0), lo(index), hi(index), 0x00, blksize, pst, 0, 0});
  }
  std::vector<CanFrame> ack(std::uint8_t ackseq, std::uint8_t blksize) {
    return req({0xA2, ackseq, blksize, 0, 0, 0, 0, 0});
  }
  std::vector<std::uint8_t> data;
};

TEST_F(SdoBlockUpload, WholeTransferWithCrc) {
  EXPECT_EQ(initiate(10), one({0xC6, 0x01, 0x20, 0x00, 100, 0, 0, 0}));
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), segs(1, 0, 10, false));
  // 100 = 14 * 7 + 2: the second sub-block has 5 segments, the last carries 2 bytes.
  EXPECT_EQ(ack(10, 10), segs(1, 70, 5, true));
  std::uint16_t crc = crc16_ccitt(data);
  EXPECT_EQ(ack(5, 10), one({0xC1 | (5 << 2), lo(crc), hi(crc), 0, 0, 0, 0, 0}));
  EXPECT_TRUE(req({0xA1, 0, 0, 0, 0, 0, 0, 0}).empty());
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoBlockUpload, AckseqBelowBlksizeResendsTheRest) {
  initiate(4);
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), segs(1, 0, 4, false));
  // Segments 3 and 4 lost: resend from byte 14, numbered from 1.
  EXPECT_EQ(ack(2, 4), segs(1, 14, 4, false));
  // Nothing received of that sub-block: resend it whole.
  EXPECT_EQ(ack(0, 4), segs(1, 14, 4, false));
  EXPECT_EQ(ack(4, 4), segs(1, 42, 4, false));
}

TEST_F(SdoBlockUpload, ClientChangesBlksizeBetweenSubBlocks) {
  initiate(3);
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), segs(1, 0, 3, false));
  EXPECT_EQ(ack(3, 7), segs(1, 21, 7, false));
  EXPECT_EQ(ack(7, 1), segs(1, 70, 1, false));
  EXPECT_EQ(ack(1, 127), segs(1, 77, 4, true));
}

// A master that did not ask for CRC still gets the real one: masters that
// check it whenever the server offered CRC (npm canopen) then agree too.
TEST_F(SdoBlockUpload, WithoutCrcEndStillCarriesTheRealCrc) {
  data = pattern(10);
  set_value(0x2001, 0, data);
  EXPECT_EQ(initiate(127, 0, false), one({0xC6, 0x01, 0x20, 0x00, 10, 0, 0, 0}));
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), segs(1, 0, 2, true));
  const std::uint16_t crc = crc16_ccitt(data);
  EXPECT_EQ(ack(2, 127), one({0xC1 | (4 << 2), lo(crc), hi(crc), 0, 0, 0, 0, 0}));
  EXPECT_TRUE(req({0xA1, 0, 0, 0, 0, 0, 0, 0}).empty());
}

TEST_F(SdoBlockUpload, LongStringObject) {
  data = value(0x2000, 0);
  std::uint32_t n = std::uint32_t(data.size());
  EXPECT_EQ(initiate(127, 0, true, 0x2000), one({0xC6, 0x00, 0x20, 0x00, lo(n), 0, 0, 0}));
  int segments = int((n + 6) / 7);
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), segs(1, 0, segments, true));
  std::uint8_t unused = std::uint8_t((7 - n % 7) % 7);
  std::uint16_t crc = crc16_ccitt(data);
  EXPECT_EQ(ack(std::uint8_t(segments), 127),
            one({std::uint8_t(0xC1 | (unused << 2)), lo(crc), hi(crc), 0, 0, 0, 0, 0}));
}

// CiA 301: pst != 0 and size <= pst -> the server may use a normal upload.
TEST_F(SdoBlockUpload, PstFallsBackToExpedited) {
  EXPECT_EQ(initiate(10, 4, true, 0x1000), one({0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoBlockUpload, PstFallsBackToSegmented) {
  EXPECT_EQ(initiate(10, 100), one({0x41, 0x01, 0x20, 0x00, 100, 0, 0, 0}));
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), std::vector<CanFrame>{upload_segments(data).front()});
  // pst below the size: block upload proper.
  req({0x80, 0x01, 0x20, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(initiate(10, 99), one({0xC6, 0x01, 0x20, 0x00, 100, 0, 0, 0}));
}

TEST_F(SdoBlockUpload, BadBlockSizeAborts) {
  EXPECT_EQ(initiate(0), aborted(0x2001, 0, SdoAbort::kBlockSize));
  EXPECT_EQ(initiate(128), aborted(0x2001, 0, SdoAbort::kBlockSize));
  initiate(10);
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(ack(10, 0), aborted(0x2001, 0, SdoAbort::kBlockSize));
  initiate(10);
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(ack(10, 200), aborted(0x2001, 0, SdoAbort::kBlockSize));
}

TEST_F(SdoBlockUpload, AckseqAboveSentAborts) {
  initiate(4);
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(ack(5, 4), aborted(0x2001, 0, SdoAbort::kSequenceNumber));
}

TEST_F(SdoBlockUpload, WrongCommandsAbort) {
  initiate(4);
  EXPECT_EQ(req({0xA2, 0, 4, 0, 0, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  initiate(4);
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  data = pattern(3);
  set_value(0x2001, 0, data);
  initiate(4);
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  ack(1, 4);  // end frame sent
  EXPECT_EQ(req({0xA3, 0, 0, 0, 0, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
}

TEST_F(SdoBlockUpload, ObjectAborts) {
  EXPECT_EQ(initiate(4, 0, true, 0x1234), aborted(0x1234, 0, SdoAbort::kNoObject));
  EXPECT_EQ(req({0xA4, 0x25, 0x61, 0x01, 4, 0, 0, 0}), aborted(0x6125, 1, SdoAbort::kWriteOnly));
}

TEST_F(SdoBlockUpload, MissingAckTimesOutAtExactTime) {
  bus_.run_until(ms(20));
  initiate(4);
  bus_.run_until(ms(300));
  req({0xA3, 0, 0, 0, 0, 0, 0, 0});
  bus_.run_until(ms(1300) - 1);
  EXPECT_TRUE(replies().empty());
  bus_.run_until(ms(1300));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].time, ms(1300));
  EXPECT_EQ(got[0].frame, abort_frame(0x2001, 0, 0x05040000));
}

}  // namespace
}  // namespace cansim::test
