#pragma once
// Reads a Server-Sent Events response (GET /jobs/{id}/events) as a client sees it: the response header, the body
// de-chunked (HTTP/1.1) and split into events. Used by the service tests (raw sockets) and the tracemeshd tests
// (curl -N output).
#include <cstdlib>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace tracemesh::testing {

struct sse_event {
  std::string name;  ///< "event:" field ("message" when absent)
  std::string data;  ///< "data:" fields joined by '\n'
};

/// The events of a complete event-stream body (comment lines skipped).
inline std::vector<sse_event> parse_sse(std::string_view body) {
  std::vector<sse_event> events;
  sse_event current;
  bool any_field = false;
  while (!body.empty()) {
    const auto newline = body.find('\n');
    std::string_view line = body.substr(0, newline);
    body = newline == std::string_view::npos ? std::string_view{} : body.substr(newline + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) {
      if (any_field) events.push_back(current.name.empty() ? sse_event{"message", current.data} : current);
      current = {};
      any_field = false;
      continue;
    }
    if (line.front() == ':') continue;
    const auto colon = line.find(':');
    std::string_view field = line.substr(0, colon);
    std::string_view value = colon == std::string_view::npos ? std::string_view{} : line.substr(colon + 1);
    if (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    if (field == "event") current.name = value;
    if (field == "data") current.data += (current.data.empty() ? "" : "\n") + std::string(value);
    any_field = true;
  }
  return events;
}

/// The body of a chunked transfer coding ("size\r\nbytes\r\n...0\r\n\r\n"); stops at an incomplete chunk.
inline std::string dechunk(std::string_view chunked) {
  std::string body;
  while (!chunked.empty()) {
    const auto line_end = chunked.find("\r\n");
    if (line_end == std::string_view::npos) break;
    const std::size_t size = std::strtoul(std::string(chunked.substr(0, line_end)).c_str(), nullptr, 16);
    if (size == 0 || chunked.size() < line_end + 2 + size + 2) break;
    body.append(chunked.substr(line_end + 2, size));
    chunked.remove_prefix(line_end + 2 + size + 2);
  }
  return body;
}

/// A raw HTTP/1.1 response (header + chunked event-stream body) as its header fields (lower-case names, with the
/// status line under ":status") and its events.
struct raw_event_stream {
  std::map<std::string, std::string> headers;
  std::vector<sse_event> events;
};

inline raw_event_stream parse_raw_event_stream(std::string_view raw) {
  raw_event_stream out;
  const auto header_end = raw.find("\r\n\r\n");
  if (header_end == std::string_view::npos) return out;
  std::string_view head = raw.substr(0, header_end);
  bool first = true;
  while (!head.empty()) {
    const auto end = head.find("\r\n");
    const std::string_view line = head.substr(0, end);
    head = end == std::string_view::npos ? std::string_view{} : head.substr(end + 2);
    if (first) {
      out.headers[":status"] = std::string(line.substr(9, 3));
      first = false;
      continue;
    }
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    std::string name(line.substr(0, colon));
    for (char& c : name) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
    std::string_view value = line.substr(colon + 1);
    while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    out.headers[name] = std::string(value);
  }
  const std::string_view body = raw.substr(header_end + 4);
  const auto coding = out.headers.find("transfer-encoding");
  const bool chunked = coding != out.headers.end() && coding->second == "chunked";
  out.events = parse_sse(chunked ? std::string_view(dechunk(body)) : body);
  return out;
}

}  // namespace tracemesh::testing
