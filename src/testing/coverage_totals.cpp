// GLSL coverage: the per-process totals of the instrumented dispatches and the LCOV tracefile
// each test process writes (coverage.cpp: the SPIR-V instrumentation).

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/coverage.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "coverage_spirv.hpp"

namespace fs = std::filesystem;

namespace penumbra::testing {
namespace detail {

// ---- the process's totals -----------------------------------------------------------------

namespace {

struct FileTotals {
  std::map<uint32_t, uint64_t> lines;
  // (line, ordinal) -> times reached, times true
  std::map<std::pair<uint32_t, uint32_t>, std::pair<uint64_t, uint64_t>> branches;
  std::map<std::string, std::pair<uint32_t, uint64_t>> functions;  // name -> line, calls
};

struct Totals {
  std::mutex mutex;
  std::map<std::string, FileTotals> files;
  bool at_exit = false;
};

Totals& totals() {
  static Totals t;
  return t;
}

}  // namespace

void record_coverage(const CoverageMap& map, std::span<const uint64_t> counts) {
  if (counts.size() != map.counters())
    throw Error("coverage: " + std::to_string(counts.size()) + " counters read back, the map has " +
                std::to_string(map.counters()));
  Totals& t = totals();
  std::lock_guard lock(t.mutex);
  // Within one dispatch a line's count is the most of its blocks' (a loop's line is in several).
  std::map<std::pair<uint32_t, uint32_t>, uint64_t> line_max;
  for (size_t b = 0; b < map.blocks.size(); ++b) {
    for (const auto& l : map.blocks[b].lines) {
      uint64_t& m = line_max[{l.file, l.line}];
      m = std::max(m, counts[b]);
    }
  }
  for (const auto& [fl, n] : line_max) t.files[map.files[fl.first]].lines[fl.second] += n;
  for (size_t j = 0; j < map.branches.size(); ++j) {
    const auto& br = map.branches[j];
    auto& v = t.files[map.files[br.at.file]].branches[{br.at.line, br.ordinal}];
    v.first += counts[br.block];
    v.second += std::min(counts[map.blocks.size() + j], counts[br.block]);
  }
  for (const auto& f : map.functions) {
    auto& v = t.files[map.files[f.at.file]].functions[f.name];
    v.first = f.at.line;
    v.second += counts[f.block];
  }
}

void reset_coverage() {
  Totals& t = totals();
  std::lock_guard lock(t.mutex);
  t.files.clear();
}

}  // namespace detail

std::optional<fs::path> coverage_directory() {
  const char* dir = std::getenv("PENUMBRA_COVERAGE");
  if (dir == nullptr || *dir == '\0') return std::nullopt;
  static std::once_flag once;
  std::call_once(once, [&] {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (!fs::is_directory(dir, ec))
      throw Error(std::string("PENUMBRA_COVERAGE='") + dir +
                  "': not a directory, and it cannot be created" +
                  (ec ? ": " + ec.message() : std::string()));
    // The tracefile is written at exit; registered after the totals exist, so it runs first.
    detail::totals();
    std::atexit([] {
      try {
        write_coverage();
      } catch (const std::exception& e) {
        std::fprintf(stderr, "[penumbra] coverage: %s\n", e.what());
        std::_Exit(1);
      }
    });
  });
  return fs::path(dir);
}

std::string coverage_tracefile() {
  auto& t = detail::totals();
  std::lock_guard lock(t.mutex);
  std::ostringstream o;
  o << "TN:\n";
  for (const auto& [file, f] : t.files) {
    o << "SF:" << file << "\n";
    for (const auto& [name, v] : f.functions) o << "FN:" << v.first << "," << name << "\n";
    size_t hit_functions = 0;
    for (const auto& [name, v] : f.functions) {
      o << "FNDA:" << v.second << "," << name << "\n";
      hit_functions += v.second > 0;
    }
    o << "FNF:" << f.functions.size() << "\nFNH:" << hit_functions << "\n";
    size_t hit_branches = 0;
    for (const auto& [at, v] : f.branches) {
      const auto& [reached, taken] = v;
      for (int side = 0; side < 2; ++side) {
        const uint64_t n = side == 0 ? taken : reached - taken;
        o << "BRDA:" << at.first << "," << at.second << "," << side << ","
          << (reached == 0 ? std::string("-") : std::to_string(n)) << "\n";
        hit_branches += reached > 0 && n > 0;
      }
    }
    o << "BRF:" << 2 * f.branches.size() << "\nBRH:" << hit_branches << "\n";
    size_t hit_lines = 0;
    for (const auto& [line, n] : f.lines) {
      o << "DA:" << line << "," << n << "\n";
      hit_lines += n > 0;
    }
    o << "LF:" << f.lines.size() << "\nLH:" << hit_lines << "\nend_of_record\n";
  }
  return o.str();
}

void write_coverage() {
  const std::optional<fs::path> dir = coverage_directory();
  if (!dir) return;
  {
    auto& t = detail::totals();
    std::lock_guard lock(t.mutex);
    if (t.files.empty()) return;  // nothing ran: no empty tracefile
  }
  std::string program = "penumbra";
  std::error_code ec;
  if (const fs::path exe = fs::read_symlink("/proc/self/exe", ec); !ec)
    program = exe.filename().string();
  const fs::path path = *dir / (program + "." + std::to_string(::getpid()) + ".info");
  const fs::path tmp = path.string() + ".tmp";
  const std::string text = coverage_tracefile();
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw Error("cannot write coverage tracefile " + tmp.string());
  }
  fs::rename(tmp, path, ec);
  if (ec) throw Error("cannot rename coverage tracefile to " + path.string() + ": " + ec.message());
}

}  // namespace penumbra::testing
