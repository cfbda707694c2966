#include "daemon/logging.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>

#include <cstdlib>

namespace cansim::daemon {

void setup_logging(const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  if (const char* js = std::getenv("JOURNAL_STREAM"); js && *js) {
    logger = std::make_shared<spdlog::logger>("cansimd", std::make_shared<spdlog::sinks::systemd_sink_st>());
    logger->set_pattern("%v");  // journald adds time, unit and priority
  } else {
    logger = std::make_shared<spdlog::logger>("cansimd", std::make_shared<spdlog::sinks::stderr_color_sink_st>());
    logger->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
  }
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

}  // namespace cansim::daemon
