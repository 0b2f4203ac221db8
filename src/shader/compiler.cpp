#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/build_info.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <penumbra/core/file.hpp>
#include <penumbra/shader/compiler.hpp>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include "compiler_detail.hpp"

namespace penumbra::shader {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// ---------------------------------------------------------------------------------------------
// Small helpers

void init_glslang() {
  // glslang keeps process-wide state (symbol tables); it is initialised once and deliberately
  // never finalized, so that Compilers may be created and destroyed at any time.
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
}

EShLanguage to_glslang(Stage stage) {
  switch (stage) {
    case Stage::vertex:
      return EShLangVertex;
    case Stage::fragment:
      return EShLangFragment;
    case Stage::compute:
      return EShLangCompute;
  }
  return EShLangCompute;
}



bool valid_identifier(std::string_view name) {
  if (name.empty()) return false;
  if (!(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_')) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

std::string rtrim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Info-log parsing

// glslang's summary lines, which follow the real errors: "N compilation errors.  No code
// generated." (no location) and "<loc>: '' : compilation terminated".
bool is_summary_line(std::string_view text) {
  size_t digits = 0;
  while (digits < text.size() && std::isdigit(static_cast<unsigned char>(text[digits]))) ++digits;
  return digits > 0 && text.substr(digits).starts_with(" compilation errors.");
}

bool is_knock_on(std::string_view message) {
  return message == "compilation terminated";
}

// Splits "name:line: rest" where name is one of the known names (longest match first, names may
// contain ':'), falling back to the first ":<digits>:" in the line.
bool split_location(const std::string& text, const SourceSet& sources, std::string& name, int& line,
                    std::string& rest) {
  auto try_name = [&](const std::string& candidate) {
    if (text.size() <= candidate.size() + 1 || text.compare(0, candidate.size(), candidate) != 0 ||
        text[candidate.size()] != ':') {
      return false;
    }
    size_t pos = candidate.size() + 1;
    const size_t digits_begin = pos;
    while (pos < text.size() && std::isdigit(static_cast<unsigned char>(text[pos]))) ++pos;
    if (pos == digits_begin || pos - digits_begin > 9 || pos >= text.size() || text[pos] != ':') {
      return false;
    }
    name = candidate;
    line = std::stoi(text.substr(digits_begin, pos - digits_begin));
    rest = text.substr(pos + 1);
    return true;
  };
  std::vector<std::string> names;
  for (const auto& [known, path] : sources.real) names.push_back(known);
  std::sort(names.begin(), names.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (const std::string& candidate : names) {
    if (try_name(candidate)) return true;
  }
  // Unknown name (e.g. an unnamed string "0"): "<anything>:<digits>: rest".
  for (size_t colon = text.find(':'); colon != std::string::npos;
       colon = text.find(':', colon + 1)) {
    if (try_name(text.substr(0, colon))) return true;
  }
  return false;
}

std::string clean_message(std::string message) {
  message = rtrim(std::move(message));
  while (!message.empty() && message.front() == ' ') message.erase(message.begin());
  // Errors handed to glslang by the includer come back as
  //   '#include' : <our message> for header name: <header>
  constexpr std::string_view include_prefix = "'#include' : ";
  if (message.starts_with(include_prefix)) {
    const size_t suffix = message.rfind(" for header name: ");
    if (suffix != std::string::npos && suffix >= include_prefix.size()) {
      return message.substr(include_prefix.size(), suffix - include_prefix.size());
    }
  }
  // Messages without a token ("'' :  syntax error, ...") lose the empty token.
  constexpr std::string_view empty_token = "'' : ";
  if (message.starts_with(empty_token)) {
    message.erase(0, empty_token.size());
    while (!message.empty() && message.front() == ' ') message.erase(message.begin());
  }
  return message;
}

std::vector<CompileError::Diagnostic> parse_info_log(const std::string& log,
                                                     const SourceSet& sources) {
  std::vector<CompileError::Diagnostic> diags;
  std::istringstream in(log);
  std::string raw;
  bool last_was_error = false;
  while (std::getline(in, raw)) {
    std::string text = rtrim(raw);
    if (text.empty()) continue;
    constexpr std::string_view error_tag = "ERROR: ";
    constexpr std::string_view warning_tag = "WARNING: ";
    if (text.starts_with(warning_tag)) {
      last_was_error = false;
      continue;
    }
    if (!text.starts_with(error_tag)) {
      // Continuation of the previous error (glslang rarely splits a message over lines).
      if (last_was_error && !diags.empty()) diags.back().message += " " + clean_message(text);
      continue;
    }
    text.erase(0, error_tag.size());
    last_was_error = false;
    if (is_summary_line(text)) continue;

    CompileError::Diagnostic diag;
    std::string name;
    std::string rest;
    if (split_location(text, sources, name, diag.line, rest)) {
      diag.message = clean_message(rest);
      if (is_knock_on(diag.message)) continue;
      if (const auto it = sources.real.find(name); it != sources.real.end()) {
        diag.file = it->second;
      } else if (name == "-1") {
        // glslang names the preamble (our injected lines) string -1.
        diag.file = sources.real.at(sources.main_name);
        const size_t index = static_cast<size_t>(std::max(diag.line, 1) - 1);
        if (index < sources.preamble_lines.size()) {
          diag.message = "in injected `" + sources.preamble_lines[index] + "`: " + diag.message;
        } else {
          diag.message = "in the injected defines: " + diag.message;
        }
        diag.line = 0;
      } else {
        diag.file = fs::path(name);
      }
    } else {
      diag.file = sources.real.at(sources.main_name);
      diag.line = 0;
      diag.message = clean_message(text);
    }
    diags.push_back(std::move(diag));
    last_was_error = true;
  }
  return diags;
}

// An included file that ends inside an #if/#ifdef/#ifndef: glslang reports "missing #endif" at
// the end of the file that included it. Finds the included file and the line of the innermost
// conditional it leaves open.
std::optional<CompileError::Diagnostic> unterminated_conditional(const SourceSet& sources) {
  for (const fs::path& path : sources.dependencies) {
    const auto it = sources.contents.find(path.string());
    if (it == sources.contents.end()) continue;  // the main file: glslang names it correctly
    std::istringstream in(it->second);
    std::string line;
    std::vector<std::pair<int, std::string>> open;  // (line, directive)
    bool in_comment = false;
    for (int n = 1; std::getline(in, line); ++n) {
      size_t i = 0;
      if (in_comment) {
        const size_t end = line.find("*/");
        if (end == std::string::npos) continue;
        in_comment = false;
        i = end + 2;
      }
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (line.compare(i, 2, "/*") == 0 && line.find("*/", i + 2) == std::string::npos) {
        in_comment = true;
        continue;
      }
      if (i >= line.size() || line[i] != '#') continue;
      ++i;
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      size_t e = i;
      while (e < line.size() && std::isalpha(static_cast<unsigned char>(line[e]))) ++e;
      const std::string directive = line.substr(i, e - i);
      if (directive == "if" || directive == "ifdef" || directive == "ifndef") {
        open.emplace_back(n, "#" + directive);
      } else if (directive == "endif" && !open.empty()) {
        open.pop_back();
      }
    }
    if (!open.empty()) {
      CompileError::Diagnostic d;
      d.file = path;
      d.line = open.back().first;
      d.message = "unterminated " + open.back().second + ": " + sources.display(path.string()) +
                  " ends before its #endif (a file cut short, or an #endif missing)";
      if (open.size() > 1)
        d.message += "; " + std::to_string(open.size() - 1) + " enclosing block(s) also open";
      return d;
    }
  }
  return std::nullopt;
}

[[noreturn]] void throw_compile_error(const std::string& log, const SourceSet& sources,
                                      std::string_view what_failed) {
  std::vector<CompileError::Diagnostic> diags = parse_info_log(log, sources);
  for (auto& diag : diags) {
    if (diag.message.find("missing #endif") == std::string::npos) continue;
    if (auto where = unterminated_conditional(sources)) {
      where->message += " (glslang reports it at " + diag.file.generic_string() + ":" +
                        std::to_string(diag.line) + ", where the including file ends)";
      diag = std::move(*where);
    }
    break;
  }
  if (diags.empty()) {
    // Nothing parseable (should not happen): keep glslang's raw text.
    std::string message = std::string(what_failed) + " failed";
    if (!rtrim(log).empty()) message += ": " + rtrim(log);
    diags.push_back({sources.real.at(sources.main_name), 0, std::move(message)});
  }
  std::string message;
  for (const auto& diag : diags) {
    if (!message.empty()) message += '\n';
    message += format_diagnostic(diag);
  }
  throw CompileError(std::move(message), std::move(diags));
}

// ---------------------------------------------------------------------------------------------

struct ShaderSetup {
  glslang::TShader shader;
  const char* text;
  int length;
  const char* name;

  ShaderSetup(EShLanguage language, const std::string& source, const std::string& source_name,
              const std::string& preamble)
      : shader(language),
        text(source.c_str()),
        length(static_cast<int>(source.size())),
        name(source_name.c_str()) {
    shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
    shader.setPreamble(preamble.c_str());
    shader.setEntryPoint("main");
    shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_2);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_5);
  }
};


constexpr int kDefaultVersion = 460;
constexpr EShMessages kMessages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules);

}  // namespace

// -----------------------------------------------------------------------------------------------

std::string_view to_string(Stage stage) {
  switch (stage) {
    case Stage::vertex:
      return "vertex";
    case Stage::fragment:
      return "fragment";
    case Stage::compute:
      return "compute";
  }
  return "unknown";
}

Stage stage_from_path(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".vert") return Stage::vertex;
  if (ext == ".frag") return Stage::fragment;
  if (ext == ".comp") return Stage::compute;
  throw Error("cannot deduce the shader stage of '" + path.string() +
              "': expected the extension .vert, .frag or .comp");
}

CompileError::CompileError(std::string message, std::vector<Diagnostic> diags)
    : Error(message), diagnostics_(std::move(diags)) {
  if (diagnostics_.empty()) diagnostics_.push_back({fs::path(), 0, std::move(message)});
}

std::string format_diagnostic(const CompileError::Diagnostic& diagnostic) {
  std::string out = diagnostic.file.string();
  if (diagnostic.line > 0) out += ":" + std::to_string(diagnostic.line);
  out += ": error: " + diagnostic.message;
  return out;
}

// glslang starts on the first compile that misses both caches (its symbol tables cost 150 ms
// or more), not here.
Compiler::Compiler(CompileOptions options) : options_(std::move(options)) {}

Compiler::Stats Compiler::stats() const {
  std::lock_guard lock(*mutex_);
  return stats_;
}

void Compiler::clear_cache() {
  std::lock_guard lock(*mutex_);
  cache_.clear();
}

CompiledShader Compiler::compile_file(const fs::path& file, std::optional<Stage> stage,
                                      const std::vector<Define>& extra_defines) {
  const Stage actual_stage = stage ? *stage : stage_from_path(file);
  const fs::path path = canonical_path(file);
  std::optional<std::string> text = is_file(path) ? read_file(path) : std::nullopt;
  if (!text) {
    throw Error("cannot read shader file: '" + printable(file.string()) + "' " +
                unreadable_reason(path));
  }
  CompiledShader result = compile(*text, path.string(), path, actual_stage, extra_defines);
  result.name = file.string();
  return result;
}

CompiledShader Compiler::compile_source(std::string_view source, std::string_view virtual_name,
                                        Stage stage, const std::vector<Define>& extra_defines) {
  CompiledShader result =
      compile(std::string(source), std::string(virtual_name), std::nullopt, stage, extra_defines);
  result.name = std::string(virtual_name);
  return result;
}

CompiledShader Compiler::compile(const std::string& main_text, const std::string& main_name,
                                 const std::optional<fs::path>& main_path, Stage stage,
                                 const std::vector<Define>& extra_defines) {
  const EShLanguage language = to_glslang(stage);

  SourceSet sources;
  sources.main_name = main_name;
  sources.main_path = main_path;
  sources.real.emplace(main_name, main_path ? *main_path : fs::path(main_name));
  if (main_path) {
    sources.dependencies.push_back(*main_path);
    sources.display_roots.push_back(main_path->parent_path());
  }
  std::vector<fs::path> include_dirs;
  for (const fs::path& dir : options_.include_dirs) {
    include_dirs.push_back(canonical_path(dir));
    sources.display_roots.push_back(include_dirs.back());
  }

  // Later defines win: the call's extra defines override the options' ones of the same name.
  std::vector<Define> defines;
  for (const std::vector<Define>* list : {&std::as_const(options_.defines), &extra_defines}) {
    for (const Define& define : *list) {
      if (!valid_identifier(define.name)) {
        throw Error("invalid define name '" + define.name + "' for shader '" + main_name + "'");
      }
      if (define.value.find_first_of("\r\n") != std::string::npos || define.value.ends_with('\\')) {
        throw Error("define '" + define.name + "' for shader '" + main_name +
                    "' has a value with a line break or a trailing backslash");
      }
      const auto same = std::find_if(defines.begin(), defines.end(),
                                     [&](const Define& d) { return d.name == define.name; });
      if (same != defines.end()) {
        same->value = define.value;
      } else {
        defines.push_back(define);
      }
    }
  }

  // The preamble goes after #version: it enables #include and holds the defines.
  sources.preamble_lines.push_back("#extension GL_GOOGLE_include_directive : enable");
  std::string define_text;
  for (const Define& define : defines) {
    std::string line = "#define " + define.name;
    if (!define.value.empty()) line += " " + define.value;
    define_text += line + "\n";
    sources.preamble_lines.push_back(std::move(line));
  }
  std::string preamble;
  for (const std::string& line : sources.preamble_lines) preamble += line + "\n";

  // The on-disk cache first: its key is everything read before the first include.
  uint64_t direct_key = 0;
  const bool disk = !options_.disk_cache_dir.empty();
  if (disk) {
    Fnv1a direct;
    direct.add_field("penumbra-shader-direct-v1 vulkan1.2 spv1.5 glslang " +
                     std::to_string(GLSLANG_VERSION_MAJOR) + "." +
                     std::to_string(GLSLANG_VERSION_MINOR) + "." +
                     std::to_string(GLSLANG_VERSION_PATCH) + GLSLANG_VERSION_FLAVOR);
    direct.add_field(to_string(stage));
    direct.add_field(options_.optimize ? "opt" : "noopt");
    direct.add_field(options_.strip_include_version ? "strip-version" : "keep-version");
    direct.add_field(options_.include_once ? "once" : "every");
    direct.add_field(options_.debug_info ? "debug-info" : "no-debug-info");
    direct.add_field(options_.keep_uncalled ? "keep-uncalled" : "drop-uncalled");
    direct.add_field(options_.overlay_include_dirs ? "layers" : "libraries");
    direct.add_field(define_text);
    direct.add_field(main_name);
    direct.add_field(main_path ? main_path->string() : std::string());
    for (const fs::path& dir : include_dirs) direct.add_field(dir.string());
    direct.add_field(main_text);
    direct_key = direct.value();
    if (std::optional<DiskEntry> entry = disk_lookup(options_.disk_cache_dir, direct_key)) {
      std::lock_guard lock(*mutex_);
      ++stats_.cache_hits;
      ++stats_.disk_hits;
      CompiledShader result;
      result.stage = stage;
      result.name = main_name;
      result.dependencies = std::move(entry->dependencies);
      result.key = entry->key;
      result.spirv = std::move(entry->spirv);
      result.notes = std::move(entry->notes);
      result.from_cache = true;
      result.from_disk = true;
      cache_.emplace(result.key, result.spirv);
      return result;
    }
  }
  init_glslang();

  // Pass 1: preprocess (expands includes, reads every dependency) to get the cache key.
  std::string preprocessed;
  {
    ShaderSetup setup(language, main_text, main_name, preamble);
    Includer includer(sources, include_dirs, options_);
    if (!setup.shader.preprocess(GetDefaultResources(), kDefaultVersion, ENoProfile, false, false,
                                 kMessages, &preprocessed, includer)) {
      throw_compile_error(setup.shader.getInfoLog(), sources, "preprocessing");
    }
  }

  Fnv1a hash;
  hash.add_field("penumbra-shader-v1 vulkan1.2 spv1.5");
  hash.add_field(to_string(stage));
  hash.add_field(options_.optimize ? "opt" : "noopt");
  hash.add_field(options_.include_once ? "once" : "every");
  hash.add_field(options_.debug_info ? "debug-info" : "no-debug-info");
  hash.add_field(options_.keep_uncalled ? "keep-uncalled" : "drop-uncalled");
  hash.add_field(define_text);
  hash.add_field(preprocessed);

  CompiledShader result;
  result.stage = stage;
  result.name = main_name;
  result.dependencies = sources.dependencies;
  result.notes = sources.notes;
  result.key = hash.value();

  {
    std::lock_guard lock(*mutex_);
    if (const auto it = cache_.find(result.key); it != cache_.end()) {
      ++stats_.cache_hits;
      result.spirv = it->second;
      result.from_cache = true;
      return result;
    }
    ++stats_.compiles;
  }

  // Pass 2: the real compile, from the original sources (served from `sources`, not re-read),
  // so that every diagnostic carries its own file and line.
  ShaderSetup setup(language, main_text, main_name, preamble);
  Includer includer(sources, include_dirs, options_);
  const EShMessages messages =
      options_.keep_uncalled ? static_cast<EShMessages>(kMessages | EShMsgKeepUncalled) : kMessages;
  if (!setup.shader.parse(GetDefaultResources(), kDefaultVersion, false, messages, includer)) {
    throw_compile_error(setup.shader.getInfoLog(), sources, "compilation");
  }
  glslang::TProgram program;
  program.addShader(&setup.shader);
  if (!program.link(messages)) {
    throw_compile_error(program.getInfoLog(), sources, "linking");
  }

  glslang::SpvOptions spv_options;
  spv_options.generateDebugInfo = options_.debug_info;
  spv_options.disableOptimizer = !options_.optimize;
  spv_options.optimizeSize = false;
  spv::SpvBuildLogger logger;
  glslang::GlslangToSpv(*program.getIntermediate(language), result.spirv, &logger, &spv_options);
  const std::string spv_messages = logger.getAllMessages();
  if (result.spirv.empty() || spv_messages.find("error:") != std::string::npos) {
    std::vector<CompileError::Diagnostic> diags{
        {sources.real.at(main_name), 0, "SPIR-V generation failed: " + rtrim(spv_messages)}};
    throw CompileError(format_diagnostic(diags[0]), std::move(diags));
  }

  {
    std::lock_guard lock(*mutex_);
    cache_.emplace(result.key, result.spirv);
  }
  if (disk) {
    std::vector<uint64_t> hashes;
    for (const fs::path& dep : result.dependencies) {
      const auto it = sources.contents.find(dep.string());
      hashes.push_back(content_hash(it != sources.contents.end() ? it->second : main_text));
    }
    disk_store(options_.disk_cache_dir, direct_key,
               DiskEntry{result.key, result.dependencies,
                         std::vector<std::string>(sources.absent.begin(), sources.absent.end()),
                         result.spirv, result.notes},
               hashes);
  }
  return result;
}

std::filesystem::path default_disk_cache_dir() {
  const char* dir = std::getenv("PENUMBRA_SHADER_CACHE_DIR");
  if (dir == nullptr || *dir == '\0' || std::string_view(dir) == "off") return {};
  return dir;
}

}  // namespace penumbra::shader
