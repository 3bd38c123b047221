#include "server/http/web_assets.hpp"

#include <algorithm>
#include <utility>
#include <vector>

#include "server/storage/content_hash.hpp"

namespace tracemesh::server {

namespace {

bool ends_with(std::string_view text, std::string_view suffix) {
  return text.size() >= suffix.size() && text.substr(text.size() - suffix.size()) == suffix;
}

std::string_view content_type_of(std::string_view path) {
  if (path == "/" || ends_with(path, ".html")) return "text/html; charset=utf-8";
  if (ends_with(path, ".js")) return "text/javascript; charset=utf-8";
  if (ends_with(path, ".css")) return "text/css; charset=utf-8";
  if (ends_with(path, ".wasm")) return "application/wasm";  // WebAssembly.instantiateStreaming insists on it
  if (ends_with(path, ".ico")) return "image/x-icon";
  return "application/octet-stream";
}

std::string_view cache_control_of(std::string_view path) {
  if (path.substr(0, 8) == "/assets/") return "public, max-age=31536000, immutable";  // the URL names the bytes
  if (path == "/favicon.ico") return "public, max-age=86400";
  return "no-cache";  // the page names the current build: always revalidated
}

std::vector<web_asset> build_table() {
  std::vector<web_asset> table;
  for (const detail::embedded_file& file : detail::embedded_web_files()) {
    sha256 hash;
    hash.update(file.bytes);
    // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "\"" + string + "\"".
    std::string etag = "\"";
    etag.append(hash.hex_digest(), 0, 32).push_back('"');
    table.push_back({file.path, content_type_of(file.path), cache_control_of(file.path), std::move(etag),
                     std::make_shared<const std::string>(file.bytes)});
  }
  return table;
}

const std::vector<web_asset>& table() {
  static const std::vector<web_asset> assets = build_table();
  return assets;
}

}  // namespace

const web_asset* find_web_asset(std::string_view path) {
  const std::vector<web_asset>& assets = table();
  const auto it = std::find_if(assets.begin(), assets.end(), [&](const web_asset& a) { return a.path == path; });
  return it == assets.end() ? nullptr : &*it;
}

std::span<const web_asset> web_assets() { return table(); }

}  // namespace tracemesh::server
