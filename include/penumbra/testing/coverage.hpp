#pragma once

// GLSL line, branch and function coverage from shader-function tests.
//
// With PENUMBRA_COVERAGE=DIR in the environment (penumbra_add_shader_tests(... COVERAGE DIR)
// sets it), every ShaderFunction wrapper is compiled with line information and with the
// functions nothing calls kept, and its SPIR-V is instrumented before the pipeline is built:
//   - a counter per basic block that holds a line of a tested file (the generated wrapper is
//     never counted), incremented by every invocation that enters the block;
//   - a counter per conditional branch (OpBranchConditional: if, loop conditions, &&, ||, and
//     ?: that glslang lowers to a branch), incremented when the condition is true; with the
//     block's count it gives both sides.
// The counters live in one more storage buffer of the wrapper's descriptor set. After each
// dispatch they are read back and added up per file and line; when the process exits they are
// written to DIR/<program>.<pid>.info as an LCOV tracefile (SF/FN/FNDA/DA/BRDA records),
// atomically. Tracefiles of many processes merge with `lcov -a` (or tools/penumbra-coverage),
// and `genhtml` turns them into HTML.
//
// Not counted: a ?: that glslang lowers to OpSelect (both sides are evaluated: no branch) and
// the cases of a switch (its lines are counted, its arms are not branches here).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace penumbra::testing {

// PENUMBRA_COVERAGE's directory; nullopt when coverage is off. Created on first use: a
// directory that cannot be created is an Error naming it (the test that compiles a wrapper
// fails).
std::optional<std::filesystem::path> coverage_directory();

// The LCOV tracefile of every count recorded in this process so far.
std::string coverage_tracefile();

// Writes coverage_tracefile() to DIR/<program>.<pid>.info now (atomically: a temporary file
// renamed into place); done at exit too. Throws penumbra::Error when it cannot be written.
void write_coverage();

}  // namespace penumbra::testing
