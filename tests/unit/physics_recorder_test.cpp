// CSV recorder: buffered, no allocation per row, readable; and the gnuplot wrapper.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "physics/recorder.hpp"
#include "support/counting_new.hpp"

using namespace cansim::physics;
using cansim::test::g_allocations;
using cansim::test::kCountingNew;

namespace {

std::string temp_path(const char* name) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir ? dir : "/tmp") + "/cansim_" + std::to_string(::getpid()) + "_" + name;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  return out;
}

Sensor demo_sensor(const FaultSet* faults) {
  SensorSpec spec;
  spec.pressure.range_min = 0;
  spec.pressure.range_max = 10e5;
  spec.pressure.adc = AdcSpec::int16_field(30000);
  spec.pressure.noise_rms = 200;
  spec.pressure.filter = {FilterType::MovingAverage, 30};
  spec.temperature.range_min = 233.15;
  spec.temperature.range_max = 398.15;
  spec.temperature.adc = AdcSpec::int16_field(30000);
  ProcessSpec ps;
  SecondOrderSpec so;
  so.setpoint.points = {{0, 2e5}, {1, 6e5}, {3, 3e5}, {4.5, 12e5}, {5.5, 2e5}};
  so.setpoint.interpolation = Interpolation::Hold;
  so.natural_frequency_hz = 1.5;
  so.damping = 0.25;
  ps.pressure = {so, PulsationSpec::piston_pump(1450, 3, 8000, 3)};
  GasVolumeSpec g;
  g.initial_temperature_k = 313.15;
  g.ambient_k.points = {{0, 293.15}};
  g.time_constant_s = 3;
  ps.temperature = {ConstantSpec{0}};
  add_gas_volume(ps, g);
  ps.pressure.pop_back();  // temperature only from the gas volume; pressure from the setpoint
  return Sensor(spec, ProcessModel(ps, 1), 7, faults);
}

}  // namespace

TEST(PhysicsRecorder, WritesRowsWithoutAllocating) {
  if (!kCountingNew) GTEST_SKIP() << "allocation counting disabled under AddressSanitizer";
  const std::string path = temp_path("rec.csv");
  FaultSet faults;
  FaultSpec open;
  open.kind = FaultKind::SensorOpen;
  open.timing.at_us = 2000000;
  open.timing.duration_us = 300000;
  faults.add(open, 0);
  Sensor s = demo_sensor(&faults);
  CsvRecorder rec;
  std::string err;
  ASSERT_TRUE(rec.open(path, &err, 4096)) << err;  // small buffer: many flushes
  const long before = g_allocations.load();
  for (int i = 0; i <= 7000; ++i) {
    const TimeUs t = static_cast<TimeUs>(i) * 1000;
    rec.record(t, s.read(t));
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_EQ(rec.rows(), 7001u);
  rec.close();
  EXPECT_FALSE(rec.failed());

  std::ifstream in(path);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line + "\n", CsvRecorder::header());
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) rows.push_back(split(line));
  ASSERT_EQ(rows.size(), 7001u);
  for (const auto& r : rows) ASSERT_EQ(r.size(), 11u);
  EXPECT_EQ(rows[1234][0], "1.234000");
  const double p = std::stod(rows[1234][3]);
  const double tp = std::stod(rows[1234][1]);
  EXPECT_NEAR(p, tp, 0.05 * 10e5);
  EXPECT_EQ(rows[2100][5], "1");  // open fault: invalid
  EXPECT_EQ(rows[1900][5], "0");
  std::remove(path.c_str());

  CsvRecorder bad;
  EXPECT_FALSE(bad.open("/nonexistent-dir/x.csv", &err));
  EXPECT_FALSE(err.empty());
  bad.record(0, s.last());  // no-op when closed
}

TEST(PhysicsRecorder, PlotScriptDrawsAPng) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "gnuplot not installed";
  const std::string csv = temp_path("plot.csv");
  const std::string png = temp_path("plot.png");
  {
    Sensor s = demo_sensor(nullptr);
    CsvRecorder rec;
    ASSERT_TRUE(rec.open(csv));
    for (int i = 0; i <= 700; ++i) rec.record(i * 10000, s.read(i * 10000));
  }
  const std::string cmd = std::string(CANSIM_SOURCE_DIR) + "/scripts/plot-recording '" + csv + "' '" + png + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(png, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  std::remove(csv.c_str());
  std::remove(png.c_str());
}

// The daemon opens recordings on its loop: a FIFO would hold open() until a
// reader came (the alarm fails the test instead of hanging), a device would
// never fill; both are refused at once.
TEST(PhysicsRecorder, OnlyARegularFileIsRecordedTo) {
  const std::string fifo = temp_path("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  CsvRecorder rec;
  std::string error;
  ::alarm(10);
  EXPECT_FALSE(rec.open(fifo, &error));
  ::alarm(0);
  EXPECT_EQ(error, fifo + ": not a regular file");
  EXPECT_FALSE(rec.open("/dev/null", &error));
  EXPECT_EQ(error, "/dev/null: not a regular file");
  EXPECT_FALSE(rec.is_open());
  std::remove(fifo.c_str());
}

// Never into the state folder (the daemon's stored parameters), by a path or a link.
TEST(PhysicsRecorder, NeverIntoTheRefusedFolder) {
  namespace fs = std::filesystem;
  const std::string state = temp_path("state");
  const std::string link = temp_path("link.csv");
  fs::create_directories(state);
  std::ofstream(state + "/vcan0@dps@0.params") << "stored";
  fs::create_symlink(state + "/vcan0@dps@0.params", link);
  CsvRecorder rec;
  std::string error;
  EXPECT_FALSE(rec.open(state + "/vcan0@dps@0.params", &error, CsvRecorder::kDefaultBuffer, state));
  EXPECT_NE(error.find("in the state folder"), std::string::npos) << error;
  EXPECT_FALSE(rec.open(state + "/../" + fs::path(state).filename().string() + "/new.csv", &error,
                        CsvRecorder::kDefaultBuffer, state));
  EXPECT_FALSE(rec.open(link, &error, CsvRecorder::kDefaultBuffer, state));
  std::ifstream in(state + "/vcan0@dps@0.params");
  std::string kept;
  in >> kept;
  EXPECT_EQ(kept, "stored");
  EXPECT_TRUE(rec.open(temp_path("ok.csv"), &error, CsvRecorder::kDefaultBuffer, state)) << error;
  rec.close();
  fs::remove_all(state);
  fs::remove(link);
  std::remove(temp_path("ok.csv").c_str());
}

// A hard link made outside the state folder is the same file under another
// name: recording to it would overwrite the stored parameters.
TEST(PhysicsRecorder, NeverToAFileWithASecondName) {
  namespace fs = std::filesystem;
  const std::string state = temp_path("state-hl");
  const std::string link = temp_path("hard.csv");
  fs::create_directories(state);
  std::ofstream(state + "/vcan0@dps@0.params") << "stored";
  fs::create_hard_link(state + "/vcan0@dps@0.params", link);
  CsvRecorder rec;
  std::string error;
  EXPECT_FALSE(rec.open(link, &error, CsvRecorder::kDefaultBuffer, state));
  EXPECT_EQ(error, link + ": a file with more than one name (hard links), which recordings never write to");
  std::ifstream in(state + "/vcan0@dps@0.params");
  std::string kept;
  in >> kept;
  EXPECT_EQ(kept, "stored");
  fs::remove_all(state);
  fs::remove(link);
}
