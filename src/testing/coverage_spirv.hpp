#pragma once

// SPIR-V instrumentation for GLSL coverage (penumbra/testing/coverage.hpp says what is counted).

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::testing::detail {

struct CoverageMap {
  struct Line {
    uint32_t file = 0;  // index into files
    uint32_t line = 0;
  };
  struct Block {  // counter index = its index in blocks
    std::vector<Line> lines;
  };
  struct Branch {  // counter index = blocks.size() + its index in branches: times true
    Line at;
    uint32_t block = 0;    // the block that ends in it: times reached
    uint32_t ordinal = 0;  // among the branches of this file and line, in module order
  };
  struct Function {
    Line at;
    std::string name;    // readable: "pcf_poisson_offset(int; vec2; float; vec2)"
    uint32_t block = 0;  // its entry block: times called
  };
  std::vector<std::string> files;
  std::vector<Block> blocks;
  std::vector<Branch> branches;
  std::vector<Function> functions;
  // The counters the instrumented code can move, in the order of a row of the buffer.
  std::vector<uint32_t> live;
  // Words per invocation in the counter buffer: live.size() rounded up to whole uvec4s.
  uint32_t row_words() const { return uint32_t(4 * ((live.size() + 3) / 4)); }
  uint32_t counters() const { return uint32_t(blocks.size() + branches.size()); }
};

struct InstrumentedSpirv {
  std::vector<uint32_t> spirv;
  CoverageMap map;
};

// Adds the counters to a compute module compiled with line information (OpString/OpLine)
// that reads gl_GlobalInvocationID. Only lines of files for which `count_file` (given the
// OpString's text) is true are counted; blocks with none of them get no counter, and only the
// functions an entry point reaches count (the others' counters are 0). Each invocation counts
// in registers and, when its entry point returns, stores its row: the buffer at (set, binding)
// is a std430 block of one uvec4 array, uint x * map.row_words() + s holding live counter s
// (map.live[s]) of invocation gl_GlobalInvocationID.x. Throws penumbra::Error on a module it
// cannot read.
InstrumentedSpirv instrument_for_coverage(std::span<const uint32_t> spirv, uint32_t set,
                                          uint32_t binding,
                                          const std::function<bool(std::string_view)>& count_file);

// glslang's mangled name ("pcf_safe_radius(f1;") made readable ("pcf_safe_radius(float)": an
// LCOV function name holds no comma); types it does not know are kept as glslang wrote them.
std::string demangle_glsl(std::string_view mangled);

// Adds one dispatch's counters (counts.size() == map.counters()) to the process's totals.
void record_coverage(const CoverageMap& map, std::span<const uint64_t> counts);

// Forgets everything recorded (tests of the harness itself).
void reset_coverage();

}  // namespace penumbra::testing::detail
