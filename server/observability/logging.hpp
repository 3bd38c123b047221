#pragma once
/// @file logging.hpp
/// Structured logs: one JSON object per line through spdlog, e.g.
///   {"ts":"2024-01-01T12:00:00.123456Z","level":"info","event":"job_done","job":"ab12…","seconds":1.2}
/// Fields are JSON-escaped by nlohmann::json before they reach spdlog (spdlog's %v does not escape).
/// Never log PQR content: callers pass sizes, ids and timings only.

#include <memory>
#include <string_view>

#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

namespace tracemesh::server {

/// A logger writing JSON lines to stderr (thread-safe). `name` is the spdlog logger name (not registered globally).
std::shared_ptr<spdlog::logger> make_json_logger(const std::string& name);

/// A logger that drops everything (unit tests).
std::shared_ptr<spdlog::logger> make_null_logger();

/// Writes {"ts","level","event", ...fields}. `fields` must be an object (anything else is logged under "data").
void log_event(spdlog::logger& logger, spdlog::level::level_enum level, std::string_view event,
               const nlohmann::json& fields = nlohmann::json::object());

}  // namespace tracemesh::server
