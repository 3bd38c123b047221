// Time and size of gzip (zlib levels 1–9) and br (brotli qualities 1–11) on one mesh file, to choose the service's
// response compression levels (server/http/content_coding.hpp). Usage: compression_levels_bench <file> [repeats=3]
// Prints one line per setting: output bytes, ratio to the input, median milliseconds to compress. Deterministic
// sizes; times need a quiet machine.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "server/http/content_coding.hpp"

namespace {

/// The service's own compressor (server/http/content_coding.hpp) at `level`.
std::string compressed(const std::string& in, tracemesh::server::content_coding coding, int level) {
  auto out = tracemesh::server::compress_at_level(in, coding, level);
  if (!out.ok()) {
    std::fprintf(stderr, "compression_levels_bench: %s\n", out.error().message().c_str());
    std::exit(1);
  }
  return std::move(*out);
}

void measure(const char* name, int level, const std::string& in, int repeats,
             const std::function<std::string(const std::string&)>& compress) {
  std::vector<double> ms;
  std::size_t bytes = 0;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    bytes = compress(in).size();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(ms.begin(), ms.end());
  std::printf("%-6s %2d  %12zu bytes  ratio %.4f  %10.1f ms  %7.1f MB/s\n", name, level, bytes,
              static_cast<double>(bytes) / static_cast<double>(in.size()), ms[ms.size() / 2],
              static_cast<double>(in.size()) / 1e3 / ms[ms.size() / 2]);
  std::fflush(stdout);  // one line at a time: a long run cut short still shows what it measured
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: compression_levels_bench <file> [repeats=3]\n");
    return 2;
  }
  std::ifstream file(argv[1], std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  const std::string in = text.str();
  if (in.empty()) {
    std::fprintf(stderr, "compression_levels_bench: cannot read %s\n", argv[1]);
    return 1;
  }
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
  std::printf("input %zu bytes, median of %d\n", in.size(), repeats);
  for (int level : {1, 3, 5, 6, 7, 9}) {
    measure("gzip", level, in, repeats, [level](const std::string& s) { return compressed(s, tracemesh::server::content_coding::gzip, level); });
  }
  for (int quality : {1, 3, 4, 5, 6, 7, 9, 11}) {
    if (quality >= 9 && in.size() > (8u << 20)) continue;  // minutes per run on a large mesh
    measure("br w22", quality, in, quality >= 9 ? 1 : repeats, [quality](const std::string& s) {
      return compressed(s, tracemesh::server::content_coding::br, quality);
    });
  }
  return 0;
}
