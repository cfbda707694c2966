// SDO server: expedited and segmented transfers, every abort path, timeouts,
// NMT gating, frame filtering (CiA 301 §7.2.4).
#include "sdo_support.hpp"

namespace cansim::test {
namespace {

using SdoServerTest = SdoFixture;

const std::string kLongString =
    "cansimd reference node: this visible string is longer than four bytes so it needs a "
    "segmented or block SDO transfer";
const std::string kDeviceName = "cansimd generic-404 pressure transmitter";

// ------------------------------------------------------------ configuration

TEST_F(SdoServerTest, ServesDefaultChannelOfItsNodeId) {
  EXPECT_TRUE(node().sdo().enabled());
  EXPECT_EQ(node().sdo().rx_cob_id(), 0x610u);
  EXPECT_EQ(node().sdo().tx_cob_id(), 0x590u);
  std::vector<std::uint32_t> ids;
  node().collect_rx_ids(ids);
  EXPECT_NE(std::find(ids.begin(), ids.end(), 0x610u), ids.end());
  // Sized once from the largest entry (0x2001 DOMAIN, 4096 bytes) + a segment.
  EXPECT_EQ(node().sdo().buffer_bytes(), 4096u + 7u);
}

TEST_F(SdoServerTest, OtherNodesRequestsAreNotAnswered) {
  EXPECT_TRUE(req(F(0x611, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0})).empty());
}

// ------------------------------------------------------------ expedited upload

TEST_F(SdoServerTest, ExpeditedUploadOf4Bytes) {
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

TEST_F(SdoServerTest, ExpeditedUploadOf3Bytes) {
  set_value(0x2000, 0, bytes_of("abc"));
  EXPECT_EQ(req({0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0}), one({0x47, 0x00, 0x20, 0x00, 'a', 'b', 'c', 0x00}));
}

TEST_F(SdoServerTest, ExpeditedUploadOf2Bytes) {
  EXPECT_EQ(req({0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0}), one({0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00}));
}

TEST_F(SdoServerTest, ExpeditedUploadOf1Byte) {
  EXPECT_EQ(req({0x40, 0x12, 0x61, 0x01, 0, 0, 0, 0}), one({0x4F, 0x12, 0x61, 0x01, 0x01, 0x00, 0x00, 0x00}));
}

TEST_F(SdoServerTest, UploadOfEmptyValueIsExpeditedWithoutSize) {
  set_value(0x2000, 0, {});
  EXPECT_EQ(req({0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0}), one({0x42, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
}

TEST_F(SdoServerTest, UploadOfSdoParameterShowsCobIds) {
  EXPECT_EQ(req({0x40, 0x00, 0x12, 0x01, 0, 0, 0, 0}), one({0x43, 0x00, 0x12, 0x01, 0x10, 0x06, 0x00, 0x00}));
  EXPECT_EQ(req({0x40, 0x00, 0x12, 0x02, 0, 0, 0, 0}), one({0x43, 0x00, 0x12, 0x02, 0x90, 0x05, 0x00, 0x00}));
}

// ------------------------------------------------------------ expedited download

TEST_F(SdoServerTest, ExpeditedDownloadOf1To4BytesWithSize) {
  EXPECT_EQ(req({0x2F, 0x01, 0x20, 0x00, 0xA1, 0xEE, 0xEE, 0xEE}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0), (std::vector<std::uint8_t>{0xA1}));
  EXPECT_EQ(req({0x2B, 0x01, 0x20, 0x00, 0xA1, 0xA2, 0xEE, 0xEE}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0), (std::vector<std::uint8_t>{0xA1, 0xA2}));
  EXPECT_EQ(req({0x27, 0x01, 0x20, 0x00, 0xA1, 0xA2, 0xA3, 0xEE}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0), (std::vector<std::uint8_t>{0xA1, 0xA2, 0xA3}));
  EXPECT_EQ(req({0x23, 0x01, 0x20, 0x00, 0xA1, 0xA2, 0xA3, 0xA4}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0), (std::vector<std::uint8_t>{0xA1, 0xA2, 0xA3, 0xA4}));
}

TEST_F(SdoServerTest, ExpeditedDownloadOfTypedValues) {
  EXPECT_EQ(req({0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0, 0}), one({0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(node().values().u(0x1017, 0), 500u);
  EXPECT_EQ(req({0x2F, 0x12, 0x61, 0x01, 0x02, 0, 0, 0}), one({0x60, 0x12, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(node().values().u(0x6112, 1), 2u);
  EXPECT_EQ(req({0x23, 0x33, 0x61, 0x01, 0x00, 0x00, 0x80, 0x3F}), one({0x60, 0x33, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_FLOAT_EQ(float(node().values().get_f(*node().od().find(0x6133, 1))), 1.0f);
}

// Without size indication the object's own length counts (1..4 bytes); the
// remaining bytes are ignored (CiA 301 e=1, s=0: unspecified length).
TEST_F(SdoServerTest, ExpeditedDownloadWithoutSizeTakesObjectLength) {
  EXPECT_EQ(req({0x22, 0x12, 0x61, 0x01, 0x02, 0x00, 0xA0, 0x00}), one({0x60, 0x12, 0x61, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x6112, 1), (std::vector<std::uint8_t>{0x02}));
  EXPECT_EQ(req({0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0xA0, 0x00}), one({0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(node().values().u(0x1017, 0), 1000u);
  EXPECT_EQ(req({0x22, 0x00, 0x12, 0x00, 0, 0, 0, 0}), aborted(0x1200, 0, SdoAbort::kReadOnly));
}

TEST_F(SdoServerTest, ExpeditedDownloadWithoutSizeToStringStopsAtNul) {
  EXPECT_EQ(req({0x22, 0x00, 0x20, 0x00, 'a', 'b', 0, 0}), one({0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2000, 0), bytes_of("ab"));
  EXPECT_EQ(req({0x22, 0x00, 0x20, 0x00, 'w', 'x', 'y', 'z'}), one({0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2000, 0), bytes_of("wxyz"));
  EXPECT_EQ(req({0x22, 0x01, 0x20, 0x00, 1, 0, 0, 0}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2001, 0), (std::vector<std::uint8_t>{1, 0, 0, 0}));
}

// ------------------------------------------------------------ initiate aborts

TEST_F(SdoServerTest, AbortsMissingObjectAndSubIndex) {
  EXPECT_EQ(req({0x40, 0x34, 0x12, 0x00, 0, 0, 0, 0}), aborted(0x1234, 0, SdoAbort::kNoObject));
  EXPECT_EQ(req({0x40, 0x18, 0x10, 0x05, 0, 0, 0, 0}), aborted(0x1018, 5, SdoAbort::kNoSubIndex));
  EXPECT_EQ(req({0x23, 0x34, 0x12, 0x00, 1, 2, 3, 4}), aborted(0x1234, 0, SdoAbort::kNoObject));
  EXPECT_EQ(req({0x21, 0x18, 0x10, 0x07, 9, 0, 0, 0}), aborted(0x1018, 7, SdoAbort::kNoSubIndex));
}

TEST_F(SdoServerTest, AbortsReadOfWriteOnly) {
  EXPECT_EQ(req({0x40, 0x25, 0x61, 0x01, 0, 0, 0, 0}), aborted(0x6125, 1, SdoAbort::kWriteOnly));
}

TEST_F(SdoServerTest, AbortsWriteOfReadOnlyAndConst) {
  EXPECT_EQ(req({0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4}), aborted(0x1000, 0, SdoAbort::kReadOnly));
  EXPECT_EQ(req({0x23, 0x08, 0x10, 0x00, 'a', 'b', 'c', 'd'}), aborted(0x1008, 0, SdoAbort::kReadOnly));
  EXPECT_EQ(req({0x21, 0x08, 0x10, 0x00, 9, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kReadOnly));
  EXPECT_EQ(value(0x1000, 0), (std::vector<std::uint8_t>{0x94, 0x01, 0x02, 0x00}));
}

TEST_F(SdoServerTest, AbortsIndicatedLengthThatDoesNotMatch) {
  EXPECT_EQ(req({0x23, 0x17, 0x10, 0x00, 1, 2, 3, 4}), aborted(0x1017, 0, SdoAbort::kLengthTooHigh));
  EXPECT_EQ(req({0x2F, 0x17, 0x10, 0x00, 1, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kLengthTooLow));
  EXPECT_EQ(req({0x2B, 0x00, 0x10, 0x00, 1, 0, 0, 0}), aborted(0x1000, 0, SdoAbort::kReadOnly));
  EXPECT_EQ(node().values().u(0x1017, 0), 1000u);
}

TEST_F(SdoServerTest, AbortsValueOutsideLimits) {
  EXPECT_EQ(req({0x2F, 0x32, 0x61, 0x01, 5, 0, 0, 0}), aborted(0x6132, 1, SdoAbort::kValueTooHigh));
  EXPECT_EQ(req({0x2F, 0x32, 0x61, 0x01, 4, 0, 0, 0}), one({0x60, 0x32, 0x61, 0x01, 0, 0, 0, 0}));
}

TEST_F(SdoServerTest, AbortsUnknownCommandSpecifier) {
  EXPECT_EQ(req({0xE0, 0x00, 0x10, 0x00, 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
  // Segment requests and block sub-commands are no initiates.
  EXPECT_EQ(req({0x00, 0x01, 0x02, 0x03, 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0x60, 0x00, 0x00, 0x00, 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xC1, 0x00, 0x00, 0x00, 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xA3, 0x00, 0x00, 0x00, 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
}

TEST_F(SdoServerTest, ClientAbortInIdleIsSilent) {
  EXPECT_TRUE(req({0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05}).empty());
}

// CiA 301: SDO frames have 8 bytes; shorter ones (and RTRs) are ignored.
TEST_F(SdoServerTest, IgnoresShortFramesAndRtr) {
  EXPECT_TRUE(req({0x40, 0x00, 0x10, 0x00}).empty());
  EXPECT_TRUE(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0}).empty());
  EXPECT_TRUE(req(CanFrame::remote(kSdoRx, 8)).empty());
  CanFrame ext = F(kSdoRx, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  ext.flags = CanFrame::kExtended;
  EXPECT_TRUE(req(ext).empty());
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).size(), 1u);
}

// ------------------------------------------------------------ segmented upload

TEST_F(SdoServerTest, SegmentedUploadOfDeviceName) {
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), one({0x41, 0x08, 0x10, 0x00, 40, 0, 0, 0}));
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), one({0x00, 'c', 'a', 'n', 's', 'i', 'm', 'd'}));
  EXPECT_EQ(req({0x70, 0, 0, 0, 0, 0, 0, 0}), one({0x10, ' ', 'g', 'e', 'n', 'e', 'r', 'i'}));
  std::vector<CanFrame> expected = upload_segments(bytes_of(kDeviceName));
  ASSERT_EQ(expected.size(), 6u);
  for (std::size_t i = 2; i < expected.size(); ++i)
    EXPECT_EQ(req({std::uint8_t(i % 2 ? 0x70 : 0x60), 0, 0, 0, 0, 0, 0, 0}), std::vector<CanFrame>{expected[i]});
  // 40 = 5 * 7 + 5: last segment t=1, n=2, c=1.
  EXPECT_EQ(expected.back(), F(kSdoTx, {0x15, 'i', 't', 't', 'e', 'r', 0, 0}));
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoServerTest, SegmentedUploadOfLongString) {
  std::vector<std::uint8_t> data = bytes_of(kLongString);
  ASSERT_EQ(value(0x2000, 0), data);
  EXPECT_EQ(req({0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0}),
            one({0x41, 0x00, 0x20, 0x00, std::uint8_t(data.size()), 0, 0, 0}));
  std::vector<CanFrame> got;
  for (std::size_t i = 0; i < (data.size() + 6) / 7; ++i) {
    auto r = req({std::uint8_t(i % 2 ? 0x70 : 0x60), 0, 0, 0, 0, 0, 0, 0});
    got.insert(got.end(), r.begin(), r.end());
  }
  EXPECT_EQ(got, upload_segments(data));
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoServerTest, SegmentedUploadAbortsWrongToggle) {
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(req({0x70, 0, 0, 0, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kToggleBit));
  EXPECT_FALSE(node().sdo().busy());
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  req({0x60, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kToggleBit));
}

TEST_F(SdoServerTest, SegmentedUploadAbortsWrongCommand) {
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(req({0x00, 0, 0, 0, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kCommandSpecifier));
}

// ------------------------------------------------------------ segmented download

TEST_F(SdoServerTest, SegmentedDownloadWithSize) {
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0}), one({0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}), one({0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2000, 0), bytes_of(kLongString));  // not written before the end
  EXPECT_EQ(req({0x19, 'h', 'i', 'j', 0, 0, 0, 0}), one({0x30, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2000, 0), bytes_of("abcdefghij"));
  EXPECT_FALSE(node().sdo().busy());
}

TEST_F(SdoServerTest, SegmentedDownloadWithoutSize) {
  EXPECT_EQ(req({0x20, 0x01, 0x20, 0x00, 0, 0, 0, 0}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x00, 1, 2, 3, 4, 5, 6, 7}), one({0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x10, 8, 9, 10, 11, 12, 13, 14}), one({0x30, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x0D, 15, 0, 0, 0, 0, 0, 0}), one({0x20, 0, 0, 0, 0, 0, 0, 0}));
  std::vector<std::uint8_t> expect;
  for (int i = 1; i <= 15; ++i) expect.push_back(std::uint8_t(i));
  EXPECT_EQ(value(0x2001, 0), expect);
}

TEST_F(SdoServerTest, SegmentedDownloadToFixedSizeObject) {
  EXPECT_EQ(req({0x21, 0x17, 0x10, 0x00, 2, 0, 0, 0}), one({0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x0B, 0xD0, 0x07, 0, 0, 0, 0, 0}), one({0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node().values().u(0x1017, 0), 2000u);
  EXPECT_EQ(req({0x21, 0x17, 0x10, 0x00, 4, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kLengthTooHigh));
  EXPECT_EQ(req({0x21, 0x17, 0x10, 0x00, 1, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kLengthTooLow));
  // Without size, the final length is checked by the write.
  req({0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(req({0x09, 1, 2, 3, 0, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kLengthTooHigh));
  EXPECT_EQ(node().values().u(0x1017, 0), 2000u);
}

TEST_F(SdoServerTest, SegmentedDownloadAbortsWrongToggle) {
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  EXPECT_EQ(req({0x10, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}), aborted(0x2000, 0, SdoAbort::kToggleBit));
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  req({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'});
  EXPECT_EQ(req({0x09, 'h', 'i', 'j', 0, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kToggleBit));
  EXPECT_EQ(value(0x2000, 0), bytes_of(kLongString));
}

TEST_F(SdoServerTest, SegmentedDownloadAbortsLengthErrors) {
  // Indicated size above the object's capacity (256).
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 0x01, 0x01, 0, 0}), aborted(0x2000, 0, SdoAbort::kLengthTooHigh));
  // More data than indicated.
  req({0x21, 0x00, 0x20, 0x00, 5, 0, 0, 0});
  EXPECT_EQ(req({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}), aborted(0x2000, 0, SdoAbort::kLengthTooHigh));
  // Less data than indicated.
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  EXPECT_EQ(req({0x03, 'a', 'b', 'c', 'd', 'e', 'f', 0}), aborted(0x2000, 0, SdoAbort::kLengthTooLow));
  // No size and more than the capacity: 37 * 7 = 259 > 256.
  req({0x20, 0x00, 0x20, 0x00, 0, 0, 0, 0});
  std::vector<CanFrame> last;
  for (int i = 0; i < 37; ++i) last = req({std::uint8_t(i % 2 ? 0x10 : 0x00), 'x', 'x', 'x', 'x', 'x', 'x', 'x'});
  EXPECT_EQ(last, aborted(0x2000, 0, SdoAbort::kLengthTooHigh));
  EXPECT_EQ(value(0x2000, 0), bytes_of(kLongString));
}

TEST_F(SdoServerTest, SegmentedDownloadAbortsWrongCommand) {
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kCommandSpecifier));
}

// ------------------------------------------------------------ transfer interplay

// A new initiate while a transfer runs: the running transfer is aborted with
// 0x05040001 (its own multiplexer); the client retries the new request.
TEST_F(SdoServerTest, NewInitiateDuringTransferAbortsIt) {
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kCommandSpecifier));
  EXPECT_FALSE(node().sdo().busy());
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kCommandSpecifier));
}

TEST_F(SdoServerTest, ClientAbortEndsTransferSilently) {
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  req({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'});
  EXPECT_TRUE(req({0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05}).empty());
  EXPECT_FALSE(node().sdo().busy());
  EXPECT_EQ(node().sdo().next_deadline(), kNever);
  // The transfer is gone: the next segment is not expected any more.
  EXPECT_EQ(req({0x19, 'h', 'i', 'j', 0, 0, 0, 0}), aborted(0, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(value(0x2000, 0), bytes_of(kLongString));
}

// ------------------------------------------------------------ timeouts

TEST_F(SdoServerTest, StalledSegmentedDownloadTimesOutAtExactTime) {
  bus_.run_until(ms(100));
  bus_.take();
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  EXPECT_EQ(node().sdo().next_deadline(), ms(1100));
  bus_.run_until(ms(1100) - 1);
  EXPECT_TRUE(replies().empty());
  bus_.run_until(ms(1100));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].time, ms(1100));
  EXPECT_EQ(got[0].frame, abort_frame(0x2000, 0, 0x05040000));
  EXPECT_FALSE(node().sdo().busy());
  EXPECT_EQ(node().sdo().next_deadline(), kNever);
}

TEST_F(SdoServerTest, EverySegmentRestartsTheTimeout) {
  bus_.run_until(ms(10));
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  bus_.run_until(ms(900));
  req({0x60, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(node().sdo().next_deadline(), ms(1900));
  bus_.run_until(ms(1899));
  EXPECT_TRUE(replies().empty());
  bus_.run_until(ms(2000));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].time, ms(1900));
  EXPECT_EQ(got[0].frame, abort_frame(0x1008, 0, 0x05040000));
}

TEST_F(SdoServerTest, IdleServerHasNoDeadline) {
  req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(node().sdo().next_deadline(), kNever);
}

// ------------------------------------------------------------ NMT gating

TEST_F(SdoServerTest, StoppedNodeDoesNotAnswerAndDropsTransfer) {
  req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0});
  bus_.inject(F(0x000, {0x02, 0x10}));
  bus_.run_for(ms(1));
  if (node().state() != NmtState::kStopped) GTEST_SKIP() << "NMT stop not implemented yet";
  bus_.take();
  EXPECT_TRUE(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}).empty());
  EXPECT_TRUE(req({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}).empty());
  bus_.run_for(ms(2000));  // no timeout abort while stopped
  EXPECT_TRUE(replies().empty());
  bus_.inject(F(0x000, {0x80, 0x10}));
  bus_.run_for(ms(1));
  bus_.take();
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

TEST_F(SdoServerTest, OperationalNodeAnswers) {
  bus_.inject(F(0x000, {0x01, 0x10}));
  bus_.run_for(ms(1));
  if (node().state() != NmtState::kOperational) GTEST_SKIP() << "NMT start not implemented yet";
  bus_.take();
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x43, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

// ------------------------------------------------------------ channel parameters

TEST(SdoServerChannel, UnconfiguredNodeHasNoServer) {
  const auto& profile = generic_with_options("");
  SimBus bus;
  SimNode& n = bus.add(profile, 0xFF);
  bus.power_on_all();
  bus.run_for(ms(1));
  EXPECT_FALSE(n->sdo().enabled());
  bus.take();
  bus.inject(F(0x6FF, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  for (const Sent& s : bus.take()) EXPECT_NE(s.frame.id, 0x67Fu);
}

TEST(SdoServerChannel, InvalidCobIdTurnsServerOff) {
  std::string yaml =
      "name: t\nnode_id: 3\nobjects:\n"
      "  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 7}\n"
      "  - {index: 0x1200, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 2}\n"
      "  - {index: 0x1200, sub: 1, kind: record, type: UNSIGNED32, access: ro, default: 0x80000603}\n"
      "  - {index: 0x1200, sub: 2, kind: record, type: UNSIGNED32, access: ro, default: 0x583}\n";
  auto profile = config::parse_profile(yaml);
  SimBus bus;
  SimNode& n = bus.add(profile, 3);
  bus.power_on_all();
  EXPECT_FALSE(n->sdo().enabled());
  std::vector<std::uint32_t> ids;
  n->sdo().collect_rx_ids(ids);
  EXPECT_TRUE(ids.empty());
}

TEST(SdoServerChannel, CobIdsComeFrom0x1200) {
  std::string yaml =
      "name: t\nnode_id: 3\nobjects:\n"
      "  - {index: 0x1000, type: UNSIGNED32, access: ro, default: 7}\n"
      "  - {index: 0x1200, sub: 0, kind: record, type: UNSIGNED8, access: ro, default: 2}\n"
      "  - {index: 0x1200, sub: 1, kind: record, type: UNSIGNED32, access: rw, default: 0x623}\n"
      "  - {index: 0x1200, sub: 2, kind: record, type: UNSIGNED32, access: rw, default: 0x5A3}\n";
  auto profile = config::parse_profile(yaml);
  SimBus bus;
  SimNode& n = bus.add(profile, 3);
  bus.power_on_all();
  bus.run_for(ms(1));
  bus.take();
  bus.inject(F(0x623, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  auto got = bus.take();
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.back().frame, F(0x5A3, {0x43, 0x00, 0x10, 0x00, 7, 0, 0, 0}));
  // Changing the CAN-ID of a valid channel is refused; invalidating it works
  // after the confirmation went out on the old ID.
  bus.inject(F(0x623, {0x23, 0x00, 0x12, 0x02, 0xB3, 0x05, 0, 0}));
  EXPECT_EQ(bus.take().back().frame, F(0x5A3, {0x80, 0x00, 0x12, 0x02, 0x30, 0x00, 0x09, 0x06}));
  bus.inject(F(0x623, {0x23, 0x00, 0x12, 0x01, 0x23, 0x06, 0, 0x80}));
  EXPECT_EQ(bus.take().back().frame, F(0x5A3, {0x60, 0x00, 0x12, 0x01, 0, 0, 0, 0}));
  EXPECT_FALSE(n->sdo().enabled());
}

}  // namespace
}  // namespace cansim::test
