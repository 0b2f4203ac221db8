#pragma once

// GLSL -> SPIR-V compilation with glslang: #include resolution (GL_GOOGLE_include_directive is
// enabled automatically), injected defines, real file:line diagnostics (also inside included
// files), an in-memory SPIR-V cache keyed on the preprocessed source and an optional on-disk
// cache that answers a later process without starting glslang at all.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <penumbra/core/error.hpp>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace penumbra::shader {

enum class Stage { vertex, fragment, compute };

std::string_view to_string(Stage stage);

// .vert -> vertex, .frag -> fragment, .comp -> compute; anything else throws penumbra::Error
// naming the file.
Stage stage_from_path(const std::filesystem::path& path);

// `#define name value`; an empty value gives `#define name`.
struct Define {
  std::string name;
  std::string value;
};

struct CompileOptions {
  // `#include "x"` is looked up in the including file's own directory first (not for the top
  // level of compile_source, which has no directory), then in these directories, in order.
  // `#include <x>` is looked up in these directories only.
  std::vector<std::filesystem::path> include_dirs;
  // Injected right after #version (via glslang's preamble), before the first line of the file.
  // A call's extra_defines override defines of the same name given here.
  std::vector<Define> defines;
  // Runs glslang's SPIR-V optimizer (when glslang was built with it). Off by default.
  bool optimize = false;
  // OpString/OpLine for every file read (each named by its canonical path, the main text by
  // its name), as glslang's -g gives: what GLSL coverage maps its counters to. Off by default.
  bool debug_info = false;
  // Functions nothing calls are kept in the SPIR-V (glslang drops them by default), so that
  // coverage can count their lines as not run. Off by default.
  bool keep_uncalled = false;
  // A leading `#version` line of an included file (third-party GLSL often starts with one,
  // which glslang rejects after the main file's) is blanked in place, line numbers kept, and
  // CompiledShader::notes says so.
  bool strip_include_version = true;
  // Every file is included at most once per compile (as if each began with `#pragma once`):
  // files without include guards that share helpers can be included together. Off: a file
  // included twice is read twice, as GLSL has it.
  bool include_once = false;
  // The on-disk SPIR-V cache's directory; empty: none (the default). An entry is keyed by
  // everything glslang would read before it reads an include (the main text and name, the
  // defines, the include directories, the stage and options, the glslang and format versions)
  // and lists every file the compile read with a hash of its contents: it answers only while
  // each of them still reads the same. A hit starts no glslang. Entries are written atomically
  // (a temporary file renamed into place); a directory that cannot be written only costs the
  // compile. An entry also lists the places searched before each include was found: a file
  // that appears there later (an overlay's copy of a library file) makes the entry stale.
  // default_disk_cache_dir() gives the directory the layers above use.
  std::filesystem::path disk_cache_dir;
  // The include directories are layers of one tree (a user's overlay over a library, files of
  // the first winning): a file's own-directory lookup `#include "x"` from <layer>/a/b.glsl tries
  // <each layer in order>/a/x instead of only its own layer's a/x. Off: include directories are
  // separate libraries.
  bool overlay_include_dirs = false;
};

struct CompiledShader {
  Stage stage = Stage::compute;
  std::vector<uint32_t> spirv;
  // The file path as given to compile_file, or the virtual name given to compile_source.
  std::string name;
  // Every file read: the main file first (compile_file only), then the included files in the
  // order they were first included; weakly_canonical and unique.
  std::vector<std::filesystem::path> dependencies;
  // Cache key: 64-bit FNV-1a of the preprocessed source (all includes expanded), the defines,
  // the stage and the options that change the output.
  uint64_t key = 0;
  bool from_cache = false;  // answered from the in-memory or the on-disk cache
  bool from_disk = false;   // answered from the on-disk cache (no glslang in this call)
  // What the compiler changed in the sources it read ("cellular2D.glsl: dropped '#version
  // 120' ..."), one line each.
  std::vector<std::string> notes;
};

// A failed compilation. what() is "file:line: error: message" for the first (real) error,
// followed by one line per further error. Knock-on summary lines of glslang ("compilation
// terminated", "N compilation errors") are dropped.
class CompileError : public penumbra::Error {
 public:
  struct Diagnostic {
    std::filesystem::path file;  // real (weakly_canonical) path, or the virtual name
    int line = 0;                // 1-based; 0 when glslang gave no location (e.g. link errors)
    std::string message;
  };

  CompileError(std::string message, std::vector<Diagnostic> diags);

  // diagnostics()[0] is the real first error; never empty.
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  std::vector<Diagnostic> diagnostics_;
};

// Formats one diagnostic as "file:line: error: message" ("file: error: message" for line 0).
std::string format_diagnostic(const CompileError::Diagnostic& diagnostic);

// Thread-compatible: one Compiler must not be used by two threads at once, but separate
// Compilers may be used concurrently. glslang is initialised once per process and never
// finalized.
class Compiler {
 public:
  explicit Compiler(CompileOptions options = {});

  // Throws CompileError on a GLSL error (including a missing include or an include cycle) and
  // penumbra::Error when the file cannot be read or its stage cannot be deduced.
  CompiledShader compile_file(const std::filesystem::path& file, std::optional<Stage> stage = {},
                              const std::vector<Define>& extra_defines = {});
  CompiledShader compile_source(std::string_view source, std::string_view virtual_name, Stage stage,
                                const std::vector<Define>& extra_defines = {});

  const CompileOptions& options() const { return options_; }

  struct Stats {
    uint64_t compiles = 0;    // full glslang compilations (cache misses), failed ones included
    uint64_t cache_hits = 0;  // requests answered from the cache (memory or disk)
    uint64_t disk_hits = 0;   // of those, answered from the on-disk cache
  };
  Stats stats() const;

  // Drops the cached SPIR-V; stats are kept.
  void clear_cache();

 private:
  CompiledShader compile(const std::string& main_text, const std::string& main_name,
                         const std::optional<std::filesystem::path>& main_path, Stage stage,
                         const std::vector<Define>& extra_defines);

  CompileOptions options_;
  // compile_file and compile_source may run on several threads at once (the program registry
  // compiles the programs one edit reaches in parallel): the cache and the stats are shared.
  mutable std::shared_ptr<std::mutex> mutex_ = std::make_shared<std::mutex>();
  std::unordered_map<uint64_t, std::vector<uint32_t>> cache_;
  Stats stats_;
};

// The shader tree (the stage files and the penumbra/ library): $PENUMBRA_SHADER_DIR when that
// is set and not empty; else, in a project built against the installed package, the package's
// copy where its find_package(Penumbra) found it (set_package_shader_dir); else the source tree
// Penumbra was built from (or, installed, CMAKE_INSTALL_FULL_DATADIR/penumbra/shaders of its
// build). The one definition every layer's default comes from.
std::filesystem::path default_shader_dir();

// Called before main() by a source that PenumbraConfig.cmake generates into every target linking
// the installed package, with the package's shader directory as that configure found it: a
// prefix installed anywhere (cmake --install --prefix DIR) works without PENUMBRA_SHADER_DIR,
// also when the test binary runs outside CTest. Returns true (for a static initializer).
bool set_package_shader_dir(const char* dir);

// The on-disk SPIR-V cache the renderer, the program registry and the test harness use:
// $PENUMBRA_SHADER_CACHE_DIR when set ("off" or empty: none), else none. Penumbra's own CTest
// runs and penumbra_add_shader_tests() set it to a directory in the build tree.
std::filesystem::path default_disk_cache_dir();

}  // namespace penumbra::shader
