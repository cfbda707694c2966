#include "ctl/capture_replay.hpp"

#include <time.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <utility>
#include <vector>

#include "ctl/candump.hpp"
#include "ctl/client_loop.hpp"
#include "ctl/frame_source.hpp"
#include "ctl/json.hpp"

namespace cansim::ctl {

// ---------------------------------------------------------------- capture

int run_capture(Connection& connection, const CaptureOptions& o, std::ostream& err) {
  std::unique_ptr<FrameSource> source = open_frame_source(o.bus, socketcand_addresses(connection), o.timeout_s);
  const bool to_stdout = o.file == "-";
  std::FILE* f = to_stdout ? stdout : std::fopen(o.file.c_str(), "w");
  if (!f) throw Failure("cannot write " + o.file + ": " + std::strerror(errno));
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(to_stdout ? nullptr : f, std::fclose);
  std::uint64_t frames = 0;
  ClientLoop loop(connection);
  loop.on_readable(source->fd(), [&] {
    RawFrame frame;
    while (source->receive(frame)) {
      const std::string line = candump_line(frame);
      if (std::fwrite(line.data(), 1, line.size(), f) != line.size()) throw Failure("cannot write " + o.file);
      ++frames;
    }
    std::fflush(f);
  });
  const int status = loop.run("capture", false);
  if (!to_stdout) err << "cansimctl: captured " << frames << " frame(s) of " << o.bus << " to " << o.file << '\n';
  return status;
}

// ---------------------------------------------------------------- replay

namespace {

constexpr std::int64_t kLeadUs = 100'000;     // the first frame's time after the call
constexpr std::int64_t kAheadUs = 1'000'000;  // frames handed over at most this far ahead
constexpr std::size_t kBatch = 512;           // frames per QueueFrames call (its bound: 1024)
constexpr std::int64_t kRetryUs = 20'000;     // the daemon's queue was full: ask again after
constexpr std::int64_t kIdleUs = 100'000;     // the longest sleep (SIGINT is seen within it)

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) { g_stop = 1; }

std::int64_t monotonic_us() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

void sleep_us(std::int64_t us) {
  if (us <= 0) return;
  timespec ts{time_t(us / 1000000), long(us % 1000000) * 1000};
  nanosleep(&ts, nullptr);  // a signal ends it early
}

// The records of a candump file that pass the filter, streamed.
class Records {
 public:
  Records(const ReplayOptions& o) : o_(o) { open(); }
  // The next frame and its time in the file (µs since the epoch); false at the end.
  bool next(std::int64_t& t, RawFrame& f) {
    std::string line, why;
    while (std::getline(in_, line)) {
      ++line_no_;
      if (parse_candump_line(line, t, f, why)) {
        if (o_.filtered && (f.id & o_.filter_mask) != (o_.filter_id & o_.filter_mask)) {
          ++filtered_;
          continue;
        }
        return true;
      }
      if (why.rfind("not replayed", 0) == 0) ++skipped_;
      else if (!why.empty()) throw Failure(o_.file + ":" + std::to_string(line_no_) + ": " + why);
    }
    return false;
  }
  void rewind() { open(); }
  std::uint64_t filtered() const { return filtered_; }
  std::uint64_t skipped() const { return skipped_; }

 private:
  void open() {
    in_ = std::ifstream(o_.file);
    if (!in_) throw Failure("cannot read " + o_.file + ": " + std::strerror(errno));
    line_no_ = 0;
  }
  const ReplayOptions& o_;
  std::ifstream in_;
  std::size_t line_no_ = 0;
  std::uint64_t filtered_ = 0, skipped_ = 0;
};

struct Timed {
  std::int64_t at;  // simulated µs
  RawFrame frame;
};

// Hands `batch` to the daemon; returns how many it took.
std::size_t queue(Connection& c, const std::string& bus, const std::vector<Timed>& batch) {
  MessagePtr reply = c.call_with(kFleetPath, kFleetInterface, "QueueFrames", [&](sd_bus_message* m) {
    expect(sd_bus_message_append(m, "s", bus.c_str()), "cannot build the call");
    expect(sd_bus_message_open_container(m, 'a', "(xuyay)"), "cannot build the call");
    for (const Timed& t : batch) {
      const RawFrame& f = t.frame;
      std::uint32_t id = f.id | (f.extended ? 0x80000000u : 0u) | (f.rtr ? 0x40000000u : 0u);
      expect(sd_bus_message_open_container(m, 'r', "xuyay"), "cannot build the call");
      expect(sd_bus_message_append(m, "xuy", t.at, id, f.dlc), "cannot build the call");
      expect(sd_bus_message_append_array(m, 'y', f.data, f.rtr ? 0 : f.dlc), "cannot build the call");
      expect(sd_bus_message_close_container(m), "cannot build the call");
    }
    expect(sd_bus_message_close_container(m), "cannot build the call");
  });
  std::uint32_t taken = 0;
  expect(sd_bus_message_read(reply.get(), "u", &taken), "unexpected reply from cansimd");
  return taken;
}

class Replay {
 public:
  Replay(Connection& c, const ReplayOptions& o) : c_(c), o_(o), records_(o) {}

  std::uint64_t run() {
    sim_at_start_ = c_.simulated_time_us();
    mono_at_start_ = monotonic_us();
    const std::int64_t start = sim_at_start_ + kLeadUs;
    bool more = advance();
    if (!more) throw Failure(o_.file + ": no frame to replay" + skipped_text());
    first_ = file_t_;
    std::vector<Timed> batch;
    while (!g_stop) {
      while (more && batch.size() < kBatch) {
        const std::int64_t at = start + offset_ + std::llround(double(file_t_ - first_) / o_.speed);
        if (at > sim_now() + kAheadUs) break;
        batch.push_back({at, frame_});
        last_at_ = at;
        more = advance();
      }
      if (!batch.empty()) {
        const std::size_t taken = queue(c_, o_.bus, batch);
        sent_ += taken;
        batch.erase(batch.begin(), batch.begin() + std::ptrdiff_t(taken));
        if (!batch.empty()) sleep_us(kRetryUs);
        continue;
      }
      if (!more && !o_.loop) break;
      if (!more) {
        more = rewind();
        continue;
      }
      const std::int64_t due = start + offset_ + std::llround(double(file_t_ - first_) / o_.speed) - kAheadUs;
      sleep_us(std::min(due - sim_now(), kIdleUs));
    }
    // Until the last frame handed over had its time (it is on the bus then).
    while (!g_stop && sim_now() < last_at_) sleep_us(std::min(last_at_ - sim_now() + 1000, kIdleUs));
    return sent_;
  }

  std::uint64_t filtered() const { return records_.filtered(); }
  std::uint64_t skipped() const { return records_.skipped(); }

  std::string skipped_text() const {
    std::string s;
    if (records_.filtered()) s += ", " + std::to_string(records_.filtered()) + " filtered out";
    if (records_.skipped()) s += ", " + std::to_string(records_.skipped()) + " error or CAN FD frame(s) not replayed";
    return s;
  }

 private:
  std::int64_t sim_now() const { return sim_at_start_ + monotonic_us() - mono_at_start_; }
  bool advance() {
    const bool got = records_.next(file_t_, frame_);
    if (got) {
      ++pass_frames_;
      last_file_t_ = file_t_;
    }
    return got;
  }
  // --loop: the file again, one mean frame gap after its last frame.
  bool rewind() {
    if (pass_frames_ == 0) throw Failure(o_.file + ": no frame to replay" + skipped_text());
    const std::int64_t span = last_file_t_ - first_;
    const std::int64_t gap = pass_frames_ > 1 ? std::max<std::int64_t>(span / std::int64_t(pass_frames_ - 1), 1) : 1000;
    offset_ += std::llround(double(span + gap) / o_.speed);
    records_.rewind();
    pass_frames_ = 0;
    const bool got = advance();
    if (got) first_ = file_t_;
    return got;
  }

  Connection& c_;
  const ReplayOptions& o_;
  Records records_;
  std::int64_t sim_at_start_ = 0, mono_at_start_ = 0;
  std::int64_t file_t_ = 0, first_ = 0, last_file_t_ = 0, offset_ = 0, last_at_ = 0;
  RawFrame frame_;
  std::uint64_t sent_ = 0, pass_frames_ = 0;
};

}  // namespace

int run_replay(Connection& connection, const ReplayOptions& o, std::ostream& out) {
  g_stop = 0;
  struct sigaction sa {};
  sa.sa_handler = on_stop;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  Replay replay(connection, o);
  const std::uint64_t sent = replay.run();
  if (o.json)
    print_json(out, {{"interface", o.bus},
                     {"file", o.file},
                     {"frames", sent},
                     {"filtered", replay.filtered()},
                     {"skipped", replay.skipped()}});
  else out << "replayed " << sent << " frame(s) of " << o.file << " onto " << o.bus << replay.skipped_text() << '\n';
  return 0;
}

}  // namespace cansim::ctl
