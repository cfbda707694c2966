#include "daemon/logging.hpp"

#include <spdlog/details/null_mutex.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <systemd/sd-journal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace cansim::daemon {

namespace {

const LogSubject* g_subject = nullptr;

int syslog_priority(spdlog::level::level_enum level) {
  switch (level) {
    case spdlog::level::trace:
    case spdlog::level::debug: return 7;
    case spdlog::level::warn: return 4;
    case spdlog::level::err: return 3;
    case spdlog::level::critical: return 2;
    default: return 6;
  }
}

class JournalSink : public spdlog::sinks::base_sink<spdlog::details::null_mutex> {
 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    std::vector<std::string> fields =
        journal_fields(msg.level, std::string_view(msg.payload.data(), msg.payload.size()));
    std::vector<iovec> iov(fields.size());
    for (std::size_t i = 0; i < fields.size(); ++i) iov[i] = {fields[i].data(), fields[i].size()};
    // Without the journal's socket the line still reaches the stream journald reads.
    if (sd_journal_sendv(iov.data(), int(iov.size())) < 0)
      std::fprintf(stderr, "%.*s\n", int(msg.payload.size()), msg.payload.data());
  }
  void flush_() override {}
};

}  // namespace

LogSubject::LogSubject(std::string_view iface, std::string_view node, std::string_view uid)
    : iface_(iface), node_(node), uid_(uid), outer_(g_subject) {
  g_subject = this;
}

LogSubject::~LogSubject() { g_subject = outer_; }

std::string_view LogSubject::current_interface() { return g_subject ? std::string_view(g_subject->iface_) : ""; }
std::string_view LogSubject::current_node() { return g_subject ? std::string_view(g_subject->node_) : ""; }
std::string_view LogSubject::current_caller_uid() { return g_subject ? std::string_view(g_subject->uid_) : ""; }

std::vector<std::string> journal_fields(spdlog::level::level_enum level, std::string_view message) {
  std::vector<std::string> f;
  f.push_back("MESSAGE=" + std::string(message));
  f.push_back("PRIORITY=" + std::to_string(syslog_priority(level)));
  f.push_back("SYSLOG_IDENTIFIER=cansimd");
  if (!LogSubject::current_interface().empty())
    f.push_back("CANSIM_IFACE=" + std::string(LogSubject::current_interface()));
  if (!LogSubject::current_node().empty()) f.push_back("CANSIM_NODE=" + std::string(LogSubject::current_node()));
  if (!LogSubject::current_caller_uid().empty())
    f.push_back("CANSIM_CALLER_UID=" + std::string(LogSubject::current_caller_uid()));
  return f;
}

bool journal_stream_matches(const char* journal_stream, dev_t dev, ino_t ino) {
  if (!journal_stream) return false;
  unsigned long long d = 0, i = 0;
  int end = 0;
  if (std::sscanf(journal_stream, "%llu:%llu%n", &d, &i, &end) != 2 || journal_stream[end] != '\0') return false;
  return d == static_cast<unsigned long long>(dev) && i == static_cast<unsigned long long>(ino);
}

void setup_logging(const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) == 0 && journal_stream_matches(std::getenv("JOURNAL_STREAM"), st.st_dev, st.st_ino)) {
    logger = std::make_shared<spdlog::logger>("cansimd", std::make_shared<JournalSink>());
    logger->set_pattern("%v");  // journald adds time, unit and priority
  } else {
    logger = std::make_shared<spdlog::logger>("cansimd", std::make_shared<spdlog::sinks::stderr_color_sink_st>());
    logger->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
  }
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

bool LineBudget::allow(std::int64_t now) {
  if (!open_ || now - opened_ >= period_) {
    open_ = true;
    opened_ = now;
    used_ = 0;
  }
  if (used_ < burst_) {
    ++used_;
    return true;
  }
  ++held_;
  return false;
}

std::string LineBudget::take_held() {
  if (held_ == 0) return {};
  const std::string out = " (and " + std::to_string(held_) + " more such line(s) held back in the " +
                          std::to_string(period_ / 1'000'000) + " s before)";
  held_ = 0;
  return out;
}

}  // namespace cansim::daemon
