// SDO vendor options (node_options.hpp, SDO section): each documented device
// deviation, frame by frame. Defaults are CiA 301 (covered by the other files).
#include "sdo_support.hpp"

namespace cansim::test {
namespace {

// GEMS 9000 (devices/gems-9000.md §6): expedited only, 0x42 responses,
// > 4-byte uploads refused with 0x08000000, everything else 0x05040001.
class GemsLike : public SdoFixture {
 protected:
  GemsLike()
      : SdoFixture(
            "sdo_expedited_only: true, sdo_upload_size_indicated: false, "
            "sdo_long_upload_abort: 0x08000000, sdo_min_request_dlc: 4") {}
};

TEST_F(GemsLike, UploadResponsesHaveNoSize) {
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  EXPECT_EQ(req({0x40, 0x12, 0x61, 0x01, 0, 0, 0, 0}), one({0x42, 0x12, 0x61, 0x01, 0x01, 0x00, 0x00, 0x00}));
}

TEST_F(GemsLike, RefusesEverythingButExpedited) {
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xC6, 0x01, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xA4, 0x01, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kGeneral));
  EXPECT_EQ(req({0x22, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0}), one({0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
}

TEST_F(GemsLike, AcceptsShortRequests) {
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00}), one({0x42, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
  EXPECT_TRUE(req({0x40, 0x00, 0x10}).empty());
  EXPECT_EQ(req({0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01}), one({0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(node().values().u(0x1017, 0), 500u);
}

// Honeywell DPS (devices/honeywell-dps.md §6, §12): segmented upload only;
// vendor abort set maps length errors to 0x08000000; optional 0x60 quirk.
class HoneywellLike : public SdoFixture {
 protected:
  HoneywellLike()
      : SdoFixture(
            "sdo_segmented_download: false, sdo_block_transfer: false, "
            "sdo_abort_map: '0x06070010=0x08000000, 0x06070012=0x08000000,0x06070013=0x08000000'") {}
};

TEST_F(HoneywellLike, SegmentedUploadStillWorks) {
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), one({0x41, 0x08, 0x10, 0x00, 40, 0, 0, 0}));
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), one({0x00, 'c', 'a', 'n', 's', 'i', 'm', 'd'}));
}

TEST_F(HoneywellLike, RefusesSegmentedDownloadAndBlock) {
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xC6, 0x01, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
  EXPECT_EQ(req({0xA4, 0x01, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kCommandSpecifier));
}

TEST_F(HoneywellLike, AbortMapTranslatesCodes) {
  EXPECT_EQ(req({0x23, 0x17, 0x10, 0x00, 1, 2, 3, 4}), aborted(0x1017, 0, SdoAbort::kGeneral));
  EXPECT_EQ(req({0x2F, 0x17, 0x10, 0x00, 1, 0, 0, 0}), aborted(0x1017, 0, SdoAbort::kGeneral));
  // Unmapped codes pass through.
  EXPECT_EQ(req({0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4}), aborted(0x1000, 0, SdoAbort::kReadOnly));
}

class Upload0x60 : public SdoFixture {
 protected:
  Upload0x60() : SdoFixture("sdo_upload_response_0x60: true") {}
};

TEST_F(Upload0x60, ExpeditedUploadAnswersWith0x60) {
  EXPECT_EQ(req({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), one({0x60, 0x00, 0x10, 0x00, 0x94, 0x01, 0x02, 0x00}));
}

// ADZ SMC (devices/adz-smc.md §7.4): segmented download only to some strings,
// other targets 0x06010000; block transfer off.
class AdzLike : public SdoFixture {
 protected:
  AdzLike() : SdoFixture("sdo_segmented_download_indices: '0x2000, 0x4020-0x4022', sdo_block_transfer: false") {}
};

TEST_F(AdzLike, SegmentedDownloadOnlyToListedObjects) {
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 3, 0, 0, 0}), one({0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(req({0x09, 'x', 'y', 'z', 0, 0, 0, 0}), one({0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(value(0x2000, 0), bytes_of("xyz"));
  EXPECT_EQ(req({0x21, 0x01, 0x20, 0x00, 3, 0, 0, 0}), aborted(0x2001, 0, SdoAbort::kUnsupportedAccess));
  // Expedited writes are not affected.
  EXPECT_EQ(req({0x2F, 0x01, 0x20, 0x00, 9, 0, 0, 0}), one({0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(req({0xC6, 0x00, 0x20, 0x00, 3, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kCommandSpecifier));
}

class RefusalCode : public SdoFixture {
 protected:
  RefusalCode() : SdoFixture("sdo_expedited_only: true, sdo_refusal_abort: 0x06010000") {}
};

TEST_F(RefusalCode, RefusalUsesTheVendorCode) {
  EXPECT_EQ(req({0x21, 0x00, 0x20, 0x00, 10, 0, 0, 0}), aborted(0x2000, 0, SdoAbort::kUnsupportedAccess));
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), aborted(0x1008, 0, SdoAbort::kCommandSpecifier));
}

class NoSizeSegmented : public SdoFixture {
 protected:
  NoSizeSegmented() : SdoFixture("sdo_upload_size_indicated: false") {}
};

TEST_F(NoSizeSegmented, InitiateResponsesCarryNoSize) {
  EXPECT_EQ(req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}), one({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}));
  req({0x80, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(req({0xA4, 0x08, 0x10, 0x00, 10, 0, 0, 0}), one({0xC4, 0x08, 0x10, 0x00, 0, 0, 0, 0}));
}

class ShortTimeout : public SdoFixture {
 protected:
  ShortTimeout() : SdoFixture("sdo_timeout_ms: 250") {}
};

TEST_F(ShortTimeout, AbortsAfter250ms) {
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  bus_.run_for(ms(249));
  EXPECT_TRUE(replies().empty());
  bus_.run_for(ms(1));
  auto got = timed_replies();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].time, ms(1) + ms(250));
  EXPECT_EQ(got[0].frame, abort_frame(0x1008, 0, 0x05040000));
}

class NoTimeout : public SdoFixture {
 protected:
  NoTimeout() : SdoFixture("sdo_timeout_ms: 0") {}
};

TEST_F(NoTimeout, TransferWaitsForever) {
  req({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(node().sdo().next_deadline(), kNever);
  bus_.run_for(ms(60000));
  EXPECT_TRUE(replies().empty());
  EXPECT_EQ(req({0x60, 0, 0, 0, 0, 0, 0, 0}), one({0x00, 'c', 'a', 'n', 's', 'i', 'm', 'd'}));
}

TEST(SdoOptionParsers, AbortMapAndIndexRanges) {
  AbortMap map;
  EXPECT_TRUE(AbortMap::parse("", map));
  EXPECT_EQ(map.count, 0);
  EXPECT_TRUE(AbortMap::parse("0x06070010=0x08000000, 1=2", map));
  EXPECT_EQ(map.count, 2);
  EXPECT_EQ(map.apply(0x06070010), 0x08000000u);
  EXPECT_EQ(map.apply(1), 2u);
  EXPECT_EQ(map.apply(3), 3u);
  EXPECT_EQ(map.text(), "0x06070010=0x08000000,0x00000001=0x00000002");
  EXPECT_FALSE(AbortMap::parse("0x06070010", map));
  EXPECT_FALSE(AbortMap::parse("x=1", map));
  EXPECT_FALSE(AbortMap::parse("1=0x100000000", map));
  RangeList r;
  EXPECT_TRUE(RangeList::parse("", 0xFFFF, r));
  EXPECT_TRUE(r.contains(0x1234));
  EXPECT_TRUE(RangeList::parse("0x2000,0x4020-0x4022", 0xFFFF, r));
  EXPECT_TRUE(r.contains(0x2000));
  EXPECT_TRUE(r.contains(0x4021));
  EXPECT_FALSE(r.contains(0x2001));
  EXPECT_EQ(r.text(0xFFFF), "0x2000,0x4020-0x4022");
  EXPECT_FALSE(RangeList::parse("0x4022-0x4020", 0xFFFF, r));
  EXPECT_FALSE(RangeList::parse("0x10000", 0xFFFF, r));
  EXPECT_FALSE(RangeList::parse("256", 0xFF, r));
}

}  // namespace
}  // namespace cansim::test
