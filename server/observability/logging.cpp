#include "server/observability/logging.hpp"

#include <spdlog/sinks/null_sink.h>
#include <spdlog/sinks/stdout_sinks.h>

namespace tracemesh::server {

namespace {

// The event object is spliced in after "level": %v receives the object's members without its braces.
constexpr const char* json_line_pattern = R"({"ts":"%Y-%m-%dT%H:%M:%S.%fZ","level":"%l",%v})";

}  // namespace

std::shared_ptr<spdlog::logger> make_json_logger(const std::string& name) {
  auto logger = std::make_shared<spdlog::logger>(name, std::make_shared<spdlog::sinks::stderr_sink_mt>());
  logger->set_pattern(json_line_pattern, spdlog::pattern_time_type::utc);
  logger->flush_on(spdlog::level::info);
  return logger;
}

std::shared_ptr<spdlog::logger> make_null_logger() {
  return std::make_shared<spdlog::logger>("null", std::make_shared<spdlog::sinks::null_sink_mt>());
}

void log_event(spdlog::logger& logger, spdlog::level::level_enum level, std::string_view event,
               const nlohmann::json& fields) {
  if (!logger.should_log(level)) return;
  nlohmann::json line = nlohmann::json::object();
  line["event"] = std::string(event);
  if (fields.is_object()) {
    for (const auto& [key, value] : fields.items()) line[key] = value;
  } else if (!fields.is_null()) {
    line["data"] = fields;
  }
  // Replace invalid UTF-8 instead of throwing: log text may carry bytes from a client.
  std::string text = line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  // Strip the outer braces; the pattern supplies them around ts/level.
  logger.log(level, std::string_view(text).substr(1, text.size() - 2));
}

}  // namespace tracemesh::server
