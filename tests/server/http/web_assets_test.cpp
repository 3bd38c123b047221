// Tests of server/http/web_assets.hpp and the viewer's routes (GET /, /favicon.ico, /assets/{build}/{file}) through a
// running service: the embedded bundle is whole, typed, cached by ETag and self-contained. The page's behaviour in
// a real browser is tested by tests/node/web_viewer_test.mjs (ctest web.viewer).
#include "server/http/web_assets.hpp"

#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

class WebAssetsTest : public service_fixture {};

/// The URLs the page loads: src= and href= attributes.
std::set<std::string> referenced_urls(const std::string& html) {
  std::set<std::string> urls;
  const std::regex attribute(R"re((?:src|href)="([^"]+)")re");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), attribute); it != std::sregex_iterator(); ++it) {
    urls.insert((*it)[1]);
  }
  return urls;
}

TEST(WebAssets, TheTableHoldsThePageTheIconAndTheBundle) {
  std::set<std::string> paths;
  for (const web_asset& asset : web_assets()) {
    paths.insert(std::string(asset.path));
    EXPECT_FALSE(asset.body->empty()) << asset.path;
    EXPECT_EQ(asset.etag.size(), 34U) << asset.path;  // quoted 32 hex digits
  }
  ASSERT_NE(find_web_asset("/"), nullptr);
  ASSERT_NE(find_web_asset("/favicon.ico"), nullptr);
  EXPECT_EQ(find_web_asset("/nope"), nullptr);
  const std::regex bundle_file(
      R"(/assets/[0-9a-f]{16}/(viewer\.js|viewer\.css|draco_wasm_wrapper\.js|draco_decoder\.wasm))");
  std::size_t bundle_files = 0;
  for (const std::string& path : paths) bundle_files += std::regex_match(path, bundle_file) ? 1 : 0;
  EXPECT_EQ(bundle_files, 4U) << "paths: " << ::testing::PrintToString(paths);
  EXPECT_EQ(paths.size(), 6U);
}

TEST_F(WebAssetsTest, ThePageAndEveryFileItLoadsAreServedWithTheirTypes) {
  start();
  const http_reply page = get("/");
  ASSERT_EQ(page.status, 200);
  EXPECT_EQ(page.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(page.header("cache-control"), "no-cache");
  EXPECT_NE(page.header("content-security-policy").find("default-src 'self'"), std::string::npos);
  EXPECT_NE(page.body.find("<canvas"), std::string::npos);
  EXPECT_EQ(page.body.find("{{ASSETS}}"), std::string::npos);

  const std::set<std::string> urls = referenced_urls(page.body);
  ASSERT_EQ(urls.size(), 3U) << page.body;  // the icon, the style sheet, the script
  std::set<std::string> types;
  for (const std::string& url : urls) {
    ASSERT_EQ(url.front(), '/') << "the page loads " << url << " from elsewhere";
    const http_reply file = get(url);
    ASSERT_EQ(file.status, 200) << url;
    EXPECT_FALSE(file.body.empty()) << url;
    EXPECT_EQ(file.header("x-content-type-options"), "nosniff") << url;
    types.insert(file.header("content-type"));
    if (url.rfind("/assets/", 0) == 0) {
      EXPECT_EQ(file.header("cache-control"), "public, max-age=31536000, immutable") << url;
    }
  }
  EXPECT_EQ(types,
            (std::set<std::string>{"image/x-icon", "text/css; charset=utf-8", "text/javascript; charset=utf-8"}));

  // The Draco decoder sits next to the script (DRACOLoader's decoder path), the wasm typed for streaming compilation.
  std::string script;
  for (const std::string& url : urls) {
    if (url.size() > 10 && url.substr(url.size() - 10) == "/viewer.js") script = url;
  }
  ASSERT_FALSE(script.empty());
  const std::string directory = script.substr(0, script.size() - std::string("viewer.js").size());
  const http_reply wasm = get(directory + "draco_decoder.wasm");
  ASSERT_EQ(wasm.status, 200);
  EXPECT_EQ(wasm.header("content-type"), "application/wasm");
  EXPECT_EQ(wasm.body.substr(0, 4), std::string("\0asm", 4));
  const http_reply wrapper = get(directory + "draco_wasm_wrapper.js");
  ASSERT_EQ(wrapper.status, 200);
  EXPECT_EQ(wrapper.header("content-type"), "text/javascript; charset=utf-8");
}

TEST_F(WebAssetsTest, AMatchingETagGets304AndHeadNoBody) {
  start();
  for (const char* path : {"/", "/favicon.ico"}) {
    const http_reply full = get(path);
    ASSERT_EQ(full.status, 200) << path;
    const std::string etag = full.header("etag");
    ASSERT_FALSE(etag.empty()) << path;
    const http_reply revalidated = get(path, "If-None-Match: " + etag + "\r\n");
    EXPECT_EQ(revalidated.status, 304) << path;
    EXPECT_TRUE(revalidated.body.empty()) << path;
    EXPECT_EQ(revalidated.header("etag"), etag) << path;
    EXPECT_EQ(get(path, "If-None-Match: \"0000\"\r\n").status, 200) << path;
    const http_reply head = request("HEAD", path);
    EXPECT_EQ(head.status, 200) << path;
    EXPECT_TRUE(head.body.empty()) << path;
    EXPECT_EQ(head.header("content-length"), std::to_string(full.body.size())) << path;
  }
}

TEST_F(WebAssetsTest, UnknownFilesAre404AndWritesAre405) {
  start();
  for (const char* path : {"/assets/0000000000000000/viewer.js", "/assets/", "/assets/../favicon.ico", "/index.html"}) {
    const http_reply missing = get(path);
    EXPECT_EQ(missing.status, 404) << path;
    EXPECT_NE(missing.body.find("\"not_found\""), std::string::npos) << path;
  }
  const http_reply post = request("POST", "/");
  EXPECT_EQ(post.status, 405);
  EXPECT_EQ(post.header("allow"), "GET, HEAD, OPTIONS");
}

}  // namespace
}  // namespace tracemesh::server::test
