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

namespace penumbra::shader {

namespace fs = std::filesystem;

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

class Fnv1a {
 public:
  void add(std::string_view bytes) {
    for (const char c : bytes) {
      hash_ ^= static_cast<unsigned char>(c);
      hash_ *= 0x100000001b3ull;
    }
  }
  // Length-prefixed, so that ("ab","c") and ("a","bc") differ.
  void add_field(std::string_view bytes) {
    add(std::to_string(bytes.size()));
    add(":");
    add(bytes);
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ull;
};

// A shader source: a regular file (after symlinks) of at most 64 MiB; anything else (a FIFO,
// /dev/zero, a directory) is not read at all.
std::optional<std::string> read_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size > (std::uintmax_t(64) << 20)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return std::move(ss).str();
}

// Why read_file(path) gave nothing, for a message: "is a character device, not a regular
// file", "not found", "is larger than 64 MiB" or "cannot be read".
std::string unreadable_reason(const fs::path& path) {
  if (std::string problem = file_problem(path); !problem.empty()) return problem;
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > (std::uintmax_t(64) << 20)) return "is larger than 64 MiB";
  return "cannot be read";
}

fs::path canonical_path(const fs::path& path) {
  std::error_code ec;
  fs::path result = fs::weakly_canonical(fs::absolute(path), ec);
  if (ec) return fs::absolute(path).lexically_normal();
  return result;
}

bool is_file(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
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
// Includer

// Everything one compilation reads, shared by the preprocess pass and the parse pass so that
// both see the same bytes even if a file changes in between.
struct SourceSet {
  std::string main_name;                        // the name glslang knows the main source by
  std::optional<fs::path> main_path;            // empty for compile_source
  std::map<std::string, fs::path> real;         // glslang name -> real path (or virtual name)
  std::map<std::string, std::string> contents;  // canonical path string -> file text
  std::map<std::string, std::string> served;    // the same, as glslang reads it
  std::vector<fs::path> dependencies;           // first-read order, unique
  std::set<std::string> absent;                 // searched before an include was found
  std::vector<fs::path> display_roots;          // for short names in messages
  std::list<std::string> messages;              // messages returned to glslang (stable storage)
  std::vector<std::string> preamble_lines;      // for errors glslang reports in the preamble
  std::vector<std::string> notes;               // what was changed in included files

  // Shortest sensible name for a message: relative to the main directory or an include
  // directory when below it, else the full path.
  std::string display(const std::string& glslang_name) const {
    if (glslang_name == main_name) {
      return main_path ? main_path->filename().generic_string() : main_name;
    }
    const fs::path path(glslang_name);
    for (const fs::path& root : display_roots) {
      const fs::path rel = path.lexically_relative(root);
      if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
    }
    return path.generic_string();
  }
};

// A leading `#version` line of an included file (after blank lines and comments), blanked in
// place so that every later line keeps its number; the directive, or nothing when there is none.
std::optional<std::string> blank_leading_version(std::string& text) {
  size_t pos = 0;
  bool in_block = false;
  while (pos < text.size()) {
    const size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line(text.data() + pos, end - pos);
    size_t i = 0;
    while (i < line.size()) {
      if (in_block) {
        const size_t close = line.find("*/", i);
        if (close == std::string_view::npos) {
          i = line.size();
          break;
        }
        in_block = false;
        i = close + 2;
      } else if (line[i] == ' ' || line[i] == '\t' || line[i] == '\r') {
        ++i;
      } else if (line.substr(i).starts_with("//")) {
        i = line.size();
      } else if (line.substr(i).starts_with("/*")) {
        in_block = true;
        i += 2;
      } else {
        break;
      }
    }
    if (i < line.size()) {
      std::string_view rest = line.substr(i);
      if (!rest.starts_with("#")) return std::nullopt;
      rest.remove_prefix(1);
      while (!rest.empty() && (rest[0] == ' ' || rest[0] == '\t')) rest.remove_prefix(1);
      if (!rest.starts_with("version")) return std::nullopt;
      std::string directive(line.substr(i));
      while (!directive.empty() && directive.back() == '\r') directive.pop_back();
      std::fill(text.begin() + std::ptrdiff_t(pos + i), text.begin() + std::ptrdiff_t(end), ' ');
      return directive;
    }
    pos = end + 1;
  }
  return std::nullopt;
}

class Includer final : public glslang::TShader::Includer {
 public:
  Includer(SourceSet& sources, const std::vector<fs::path>& include_dirs,
           const CompileOptions& options)
      : sources_(sources), include_dirs_(include_dirs), options_(options) {}

  IncludeResult* includeLocal(const char* header_name, const char* includer_name,
                              size_t depth) override {
    std::vector<fs::path> dirs;
    if (const auto it = sources_.real.find(includer_name);
        it != sources_.real.end() && (includer_name != sources_.main_name || sources_.main_path)) {
      add_own_directory(it->second.parent_path(), dirs);
    }
    dirs.insert(dirs.end(), include_dirs_.begin(), include_dirs_.end());
    IncludeResult* result = resolve(header_name, includer_name, depth, dirs);
    if (result == nullptr || result->headerName.empty()) {
      // glslang calls includeSystem next for the same directive: hand the error over there
      // (an error result returned here would be discarded).
      if (result != nullptr) {
        pending_ = Pending{header_name, includer_name, depth,
                           std::string(result->headerData, result->headerLength)};
        delete result;
      }
      return nullptr;
    }
    return result;
  }

  IncludeResult* includeSystem(const char* header_name, const char* includer_name,
                               size_t depth) override {
    if (pending_ && pending_->header == header_name && pending_->includer == includer_name &&
        pending_->depth == depth) {
      const std::string message = std::move(pending_->message);
      pending_.reset();
      return error_result(message);
    }
    pending_.reset();
    IncludeResult* result = resolve(header_name, includer_name, depth, include_dirs_);
    return result;
  }

  void releaseInclude(IncludeResult* result) override { delete result; }

 private:
  struct Pending {
    std::string header;
    std::string includer;
    size_t depth = 0;
    std::string message;
  };

  IncludeResult* error_result(std::string message) {
    const std::string& stored = sources_.messages.emplace_back(std::move(message));
    return new IncludeResult("", stored.data(), stored.size(), nullptr);
  }

  // The includer's directory; with overlay_include_dirs, the same directory in every layer (in
  // layer order) when it lies in one of them.
  void add_own_directory(const fs::path& own, std::vector<fs::path>& dirs) const {
    if (options_.overlay_include_dirs) {
      for (const fs::path& root : include_dirs_) {
        const fs::path rel = own.lexically_relative(root);
        if (rel.empty() || *rel.begin() == "..") continue;
        for (const fs::path& layer : include_dirs_) dirs.push_back((layer / rel).lexically_normal());
        return;
      }
    }
    dirs.push_back(own);
  }

  // The include stack: stack_[0] is the main source, stack_[d] the file included at depth d.
  // glslang releases an include only when it is done with it, but the depth it passes is the
  // reliable signal, so the stack is cut back to the includer's depth on every request.
  void sync_stack(const std::string& includer_name, size_t depth) {
    if (stack_.empty()) stack_.push_back(sources_.main_name);
    if (depth == 0) depth = 1;
    if (stack_.size() > depth) stack_.resize(depth);
    while (stack_.size() < depth) stack_.push_back(includer_name);
    stack_.back() = includer_name;
  }

  IncludeResult* resolve(const std::string& header, const std::string& includer_name, size_t depth,
                         const std::vector<fs::path>& dirs) {
    sync_stack(includer_name, depth);
    // A candidate that exists but is no regular file (a directory, a link to /dev/zero) is
    // named when no later directory has the header: "cannot find" would send the user looking
    // for a file that is there.
    std::string not_a_file;
    for (const fs::path& dir : dirs) {
      const fs::path candidate = dir / header;
      if (!is_file(candidate)) {
        if (const std::string problem = file_problem(candidate);
            not_a_file.empty() && problem != "not found") {
          not_a_file = "include \"" + header + "\" (" + candidate.lexically_normal().string() +
                       ") " + problem;
        } else if (problem == "not found") {
          sources_.absent.insert(candidate.lexically_normal().string());
        }
        continue;
      }
      const fs::path path = canonical_path(candidate);
      const std::string name = path.string();

      if (const auto it = std::find(stack_.begin(), stack_.end(), name); it != stack_.end()) {
        std::string message = "include cycle: ";
        for (auto jt = it; jt != stack_.end(); ++jt) message += sources_.display(*jt) + " -> ";
        message += sources_.display(name);
        return error_result(std::move(message));
      }

      auto content = sources_.contents.find(name);
      if (content == sources_.contents.end()) {
        std::optional<std::string> text = read_file(path);
        if (!text) {
          return error_result("cannot read include \"" + header + "\": " + name + " " +
                              unreadable_reason(path));
        }
        // The contents map keeps what the file holds (the disk cache hashes it); the text
        // glslang reads may have its #version blanked.
        content = sources_.contents.emplace(name, *text).first;
        sources_.dependencies.push_back(path);
        if (options_.strip_include_version) {
          if (std::optional<std::string> directive = blank_leading_version(*text)) {
            sources_.notes.push_back(sources_.display(name) + ": dropped '" + *directive +
                                     "' (an included file; CompileOptions::"
                                     "strip_include_version)");
          }
        }
        sources_.served.emplace(name, std::move(*text));
      }
      sources_.real.emplace(name, path);
      stack_.push_back(name);
      if (options_.include_once && !served_.insert(name).second) {
        return new IncludeResult(name, "", 0, nullptr);  // already included: nothing again
      }
      const std::string& served = sources_.served.at(name);
      return new IncludeResult(name, served.data(), served.size(), nullptr);
    }

    if (!not_a_file.empty()) return error_result(std::move(not_a_file));
    std::string message = "cannot find include \"" + header + "\" (searched: ";
    if (dirs.empty()) message += "no include directories";
    for (size_t i = 0; i < dirs.size(); ++i) {
      if (i > 0) message += ", ";
      message += dirs[i].generic_string();
    }
    message += ")";
    return error_result(std::move(message));
  }

  SourceSet& sources_;
  const std::vector<fs::path>& include_dirs_;
  const CompileOptions& options_;
  std::vector<std::string> stack_;
  std::optional<Pending> pending_;
  std::set<std::string> served_;  // include_once: files already given to this pass
};

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

// ---------------------------------------------------------------------------------------------
// The on-disk cache. One file per direct key, <dir>/<key, 16 hex digits>.spv:
//   penumbra-spirv-cache 1\n
//   key <the preprocessed key, hex>\n
//   dep <hash of the contents, hex> <path>\n     one per file read, in first-read order
//   absent <path>\n                               one per place searched before an include
//                                                 was found: the entry is stale once it exists
//   note <text>\n                                 one per CompiledShader::notes line
//   spirv <word count>\n
//   <the words, native byte order>

constexpr std::string_view kDiskMagic = "penumbra-spirv-cache 2\n";

std::string hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

uint64_t content_hash(std::string_view text) {
  Fnv1a h;
  h.add_field(text);
  return h.value();
}

struct DiskEntry {
  uint64_t key = 0;
  std::vector<fs::path> dependencies;
  std::vector<std::string> absent;
  std::vector<uint32_t> spirv;
  std::vector<std::string> notes;
};

// The entry for direct_key when every file it lists still hashes the same; nothing otherwise
// (missing, unreadable, malformed or stale entries alike).
std::optional<DiskEntry> disk_lookup(const fs::path& dir, uint64_t direct_key) {
  const std::optional<std::string> file = read_file(dir / (hex64(direct_key) + ".spv"));
  if (!file || !file->starts_with(kDiskMagic)) return std::nullopt;
  std::string_view rest = std::string_view(*file).substr(kDiskMagic.size());
  auto line = [&rest]() -> std::optional<std::string_view> {
    const size_t end = rest.find('\n');
    if (end == std::string_view::npos) return std::nullopt;
    std::string_view l = rest.substr(0, end);
    rest.remove_prefix(end + 1);
    return l;
  };
  DiskEntry entry;
  const auto key_line = line();
  if (!key_line || !key_line->starts_with("key ")) return std::nullopt;
  entry.key = std::strtoull(std::string(key_line->substr(4)).c_str(), nullptr, 16);
  for (;;) {
    const auto l = line();
    if (!l) return std::nullopt;
    if (l->starts_with("spirv ")) {
      const size_t words = std::strtoull(std::string(l->substr(6)).c_str(), nullptr, 10);
      if (words == 0 || rest.size() != words * sizeof(uint32_t)) return std::nullopt;
      entry.spirv.resize(words);
      std::memcpy(entry.spirv.data(), rest.data(), rest.size());
      return entry;
    }
    if (l->starts_with("note ")) {
      entry.notes.emplace_back(l->substr(5));
      continue;
    }
    if (l->starts_with("absent ")) {
      std::error_code ec;
      if (fs::symlink_status(fs::path(std::string(l->substr(7))), ec).type() !=
          fs::file_type::not_found)
        return std::nullopt;  // something is there now: the include may resolve elsewhere
      entry.absent.emplace_back(l->substr(7));
      continue;
    }
    if (!l->starts_with("dep ") || l->size() < 4 + 16 + 2) return std::nullopt;
    const uint64_t want = std::strtoull(std::string(l->substr(4, 16)).c_str(), nullptr, 16);
    const fs::path path(std::string(l->substr(4 + 16 + 1)));
    const std::optional<std::string> text = read_file(path);
    if (!text || content_hash(*text) != want) return std::nullopt;
    entry.dependencies.push_back(path);
  }
}

// Writes the entry through a temporary file renamed into place; false when it could not.
bool disk_store(const fs::path& dir, uint64_t direct_key, const DiskEntry& entry,
                const std::vector<uint64_t>& dependency_hashes) {
  std::string text(kDiskMagic);
  text += "key " + hex64(entry.key) + "\n";
  for (size_t i = 0; i < entry.dependencies.size(); ++i) {
    const std::string path = entry.dependencies[i].string();
    if (path.find('\n') != std::string::npos) return false;
    text += "dep " + hex64(dependency_hashes[i]) + " " + path + "\n";
  }
  for (const std::string& absent : entry.absent) {
    if (absent.find('\n') != std::string::npos) return false;
    text += "absent " + absent + "\n";
  }
  for (const std::string& note : entry.notes) {
    if (note.find('\n') != std::string::npos) return false;
    text += "note " + note + "\n";
  }
  text += "spirv " + std::to_string(entry.spirv.size()) + "\n";
  text.append(reinterpret_cast<const char*>(entry.spirv.data()),
              entry.spirv.size() * sizeof(uint32_t));
  std::error_code ec;
  fs::create_directories(dir, ec);
  static std::atomic<uint64_t> counter{0};
  const fs::path final_path = dir / (hex64(direct_key) + ".spv");
  const fs::path temp = dir / (hex64(direct_key) + ".tmp." + std::to_string(::getpid()) + "." +
                               std::to_string(counter++));
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out.write(text.data(), std::streamsize(text.size()));
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      return false;
    }
  }
  fs::rename(temp, final_path, ec);
  if (ec) fs::remove(temp, ec);
  return !ec;
}

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
