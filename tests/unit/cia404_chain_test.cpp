// CiA 404 chain through the OD: representations, digits, units, offset,
// autozero, span status and live values.
#include "cia404_support.hpp"

namespace cansim::test {
namespace {

using Chain = ChainFixture;

TEST_F(Chain, FloatAndIntegerViewsOfTheSameValue) {
  source->pressure = [](TimeUs) { return 2.345678e5; };
  EXPECT_FLOAT_EQ(f(0x6130, 1), 2.345678f);
  EXPECT_EQ(u(0x6132, 1), 2u);
  EXPECT_EQ(i16(0x7130, 1), 235);  // 234.5678 -> 235
  EXPECT_EQ(i32(0x9130, 1), 235);
  ASSERT_EQ(wu8(0x6132, 1, 4), SdoAbort::kNone);
  EXPECT_EQ(i16(0x7130, 1), 23457);
  EXPECT_EQ(i32(0x9130, 1), 23457);
  ASSERT_EQ(wu8(0x6132, 1, 0), SdoAbort::kNone);
  EXPECT_EQ(i32(0x9130, 1), 2);
}

TEST_F(Chain, IntegerPvRoundsHalfAwayFromZero) {
  source->pressure = [](TimeUs) { return 1.125e5; };  // exact in float: 112.5 at 2 digits
  bus.run_for(1);                                     // a new instant: a source is fixed within one
  EXPECT_EQ(i16(0x7130, 1), 113);
  source->pressure = [](TimeUs) { return -1.125e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(i16(0x7130, 1), -113);
  // float32(1.92) x 100 = 191.99999... must still give 192.
  source->pressure = [](TimeUs) { return 1.92e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(i32(0x9130, 1), 192);
}

TEST_F(Chain, Integer16Saturates) {
  ASSERT_EQ(wu8(0x6132, 1, 4), SdoAbort::kNone);
  source->pressure = [](TimeUs) { return 9.9e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(i16(0x7130, 1), 32767);
  EXPECT_EQ(i32(0x9130, 1), 99000);
  source->pressure = [](TimeUs) { return -5.0e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(i16(0x7130, 1), -32768);
  EXPECT_EQ(i32(0x9130, 1), -50000);
}

TEST_F(Chain, DecimalDigitsOutsideTheOdRangeAbort) {
  EXPECT_EQ(wu8(0x6132, 1, 5), SdoAbort::kValueTooHigh);
  EXPECT_EQ(u(0x6132, 1), 2u);
  EXPECT_EQ(wu8(0x6132, 1, 4), SdoAbort::kNone);
}

TEST_F(Chain, UnitChangeConvertsDependentObjects) {
  ASSERT_EQ(wf(0x6124, 1, 0.5f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6148, 1, 1.0f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6149, 1, 9.0f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6133, 1, 0.1f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6134, 1, 2.0f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6135, 1, 8.0f), SdoAbort::kNone);
  ASSERT_EQ(wf(0x6136, 1, 0.05f), SdoAbort::kNone);
  EXPECT_FLOAT_EQ(f(0x6130, 1), 5.5f);
  ASSERT_EQ(wu32(0x6131, 1, 0x03220000), SdoAbort::kNone);  // kPa
  EXPECT_EQ(u(0x6131, 1), 0x03220000u);
  EXPECT_FLOAT_EQ(f(0x6124, 1), 50.0f);
  EXPECT_FLOAT_EQ(f(0x6148, 1), 100.0f);
  EXPECT_FLOAT_EQ(f(0x6149, 1), 900.0f);
  EXPECT_FLOAT_EQ(f(0x6133, 1), 10.0f);
  EXPECT_FLOAT_EQ(f(0x6134, 1), 200.0f);
  EXPECT_FLOAT_EQ(f(0x6135, 1), 800.0f);
  EXPECT_FLOAT_EQ(f(0x6136, 1), 5.0f);
  EXPECT_FLOAT_EQ(f(0x6130, 1), 550.0f);
  // psi: 1 psi = 6894.757293168361 Pa.
  ASSERT_EQ(wu32(0x6131, 1, 0x00AB0000), SdoAbort::kNone);
  EXPECT_NEAR(f(0x6149, 1), 9.0e5 / 6894.757293168361, 1e-4);
  EXPECT_NEAR(f(0x6130, 1), 5.5e5 / 6894.757293168361, 1e-4);
}

TEST_F(Chain, TemperatureUnitChangeShiftsAbsoluteValuesOnly) {
  source->temperature = [](TimeUs) { return 298.15; };  // 25 degC
  ASSERT_EQ(wf(0x6124, 2, 1.0f), SdoAbort::kNone);      // offset: a difference
  EXPECT_FLOAT_EQ(f(0x6130, 2), 26.0f);
  ASSERT_EQ(wu32(0x6131, 2, 0x00AC0000), SdoAbort::kNone);  // degF
  EXPECT_FLOAT_EQ(f(0x6124, 2), 1.8f);
  EXPECT_FLOAT_EQ(f(0x6148, 2), -40.0f);
  EXPECT_FLOAT_EQ(f(0x6149, 2), 257.0f);
  EXPECT_FLOAT_EQ(f(0x6130, 2), 78.8f);
  EXPECT_EQ(i16(0x7130, 2), 788);                           // 1 digit
  ASSERT_EQ(wu32(0x6131, 2, 0x00050000), SdoAbort::kNone);  // K
  EXPECT_NEAR(f(0x6149, 2), 398.15f, 1e-3);
  EXPECT_NEAR(f(0x6124, 2), 1.0f, 1e-6);
}

TEST_F(Chain, UnknownOrForeignUnitAborts) {
  EXPECT_EQ(wu32(0x6131, 1, 0x00030000), SdoAbort::kInvalidValue);
  EXPECT_EQ(wu32(0x6131, 1, 0x002D0000), SdoAbort::kInvalidValue);  // degC on the pressure channel
  EXPECT_EQ(wu32(0x6131, 2, 0x004E0000), SdoAbort::kInvalidValue);
  EXPECT_EQ(u(0x6131, 1), 0x004E0000u);
  EXPECT_EQ(wu32(0x6131, 1, 0xFD4E0000), SdoAbort::kNone);  // mbar
  EXPECT_FLOAT_EQ(f(0x6130, 1), 5000.0f);
}

TEST_F(Chain, AutozeroWithSignatureZeroesThePv) {
  source->pressure = [](TimeUs) { return 3.0e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(wu32(0x6125, 1, 0x12345678), SdoAbort::kInvalidValue);
  EXPECT_FLOAT_EQ(f(0x6130, 1), 3.0f);
  SdoAbort why;
  read(0x6125, 1, &why);
  EXPECT_EQ(why, SdoAbort::kWriteOnly);
  ASSERT_EQ(wu32(0x6125, 1, 0x6F72657A), SdoAbort::kNone);
  EXPECT_FLOAT_EQ(f(0x6124, 1), -3.0f);
  EXPECT_FLOAT_EQ(f(0x6130, 1), 0.0f);
  source->pressure = [](TimeUs) { return 4.0e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_FLOAT_EQ(f(0x6130, 1), 1.0f);
}

TEST_F(Chain, SpanStatusBits) {
  source->pressure = [](TimeUs) { return 5.0e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(u(0x6150, 1), 0x00u);
  source->pressure = [](TimeUs) { return 10.5e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(u(0x6150, 1), 0x02u);
  source->pressure = [](TimeUs) { return -0.5e5; };
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(u(0x6150, 1), 0x04u);
  ASSERT_EQ(wf(0x6148, 1, -1.0f), SdoAbort::kNone);
  EXPECT_EQ(u(0x6150, 1), 0x00u);
  source->status = physics::kStatusInvalid;
  bus.run_for(1);  // a new instant: a source is fixed within one
  EXPECT_EQ(u(0x6150, 1), 0x01u);
}

TEST_F(Chain, TwoReadsOfALiveValueAtDifferentTimesDiffer) {
  source->pressure = [](TimeUs t) { return 1.0e5 + double(t) * 0.1; };  // 1 bar/s ramp... per 10 s
  const float a = f(0x6130, 1);
  bus.run_for(ms(500));
  const float b = f(0x6130, 1);
  EXPECT_FLOAT_EQ(a, float((1.0e5 + double(ms(1)) * 0.1) / 1e5));
  EXPECT_FLOAT_EQ(b, float((1.0e5 + double(ms(501)) * 0.1) / 1e5));
  EXPECT_NE(a, b);
}

TEST_F(Chain, NegativeDeltaAndBadFilterSettingsAbort) {
  EXPECT_EQ(wf(0x6133, 1, -0.1f), SdoAbort::kValueTooLow);
  EXPECT_EQ(wf(0x6136, 1, -0.1f), SdoAbort::kValueTooLow);
  EXPECT_EQ(wu8(0x61A0, 1, 3), SdoAbort::kValueTooHigh);  // OD high: 2
  EXPECT_EQ(wu16(0x61A1, 1, 0), SdoAbort::kValueTooLow);
}

// A profile that restricts digits per unit and rejects incompatible unit changes.
TEST(ChainProfile, DigitsRangePerUnit) {
  config::Profile p = prepared_repo_yaml("generic-404", [](YAML::Node& root) {
    root["vendor"] = YAML::Load(R"(
cia404:
  digits_on_unit_change: reject
  channels:
    - {sub: 1, quantity: pressure, units: [{unit: bar, max_digits: 3}, {unit: mbar, max_digits: 1}, psi]}
    - {sub: 2, quantity: temperature}
)");
  });
  struct F : ChainFixture {
    void TestBody() override {}
  } fx;
  fx.build(p);
  EXPECT_EQ(fx.wu8(0x6132, 1, 4), SdoAbort::kValueTooHigh);  // bar: at most 3
  EXPECT_EQ(fx.wu8(0x6132, 1, 3), SdoAbort::kNone);
  EXPECT_EQ(fx.wu32(0x6131, 1, 0xFD4E0000), SdoAbort::kParamIncompatible);
  EXPECT_EQ(fx.wu8(0x6132, 1, 1), SdoAbort::kNone);
  EXPECT_EQ(fx.wu32(0x6131, 1, 0xFD4E0000), SdoAbort::kNone);
  EXPECT_EQ(fx.wu32(0x6131, 1, 0x03220000), SdoAbort::kInvalidValue);  // kPa not listed
}

}  // namespace
}  // namespace cansim::test
