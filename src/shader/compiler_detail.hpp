#pragma once
// The compiler's private parts (src/shader/compiler.cpp): what one compile reads (SourceSet),
// glslang's includer over the include directories, and the on-disk SPIR-V cache's entries
// (compiler_sources.cpp).
#include <glslang/Public/ShaderLang.h>

#include <cstdint>
#include <filesystem>
#include <list>
#include <map>
#include <optional>
#include <penumbra/core/file.hpp>
#include <penumbra/shader/compiler.hpp>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::shader::detail {

namespace fs = std::filesystem;

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
std::optional<std::string> read_file(const fs::path& path);
// Why read_file(path) gave nothing, for a message: "is a character device, not a regular
// file", "not found", "is larger than 64 MiB" or "cannot be read".
std::string unreadable_reason(const fs::path& path);
fs::path canonical_path(const fs::path& path);
bool is_file(const fs::path& path);

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
std::optional<std::string> blank_leading_version(std::string& text);

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
// The on-disk cache. One file per direct key, <dir>/<key, 16 hex digits>.spv:
//   penumbra-spirv-cache 2\n
//   key <the preprocessed key, hex>\n
//   dep <hash of the contents, hex> <path>\n     one per file read, in first-read order
//   absent <path>\n                               one per place searched before an include
//                                                 was found: the entry is stale once it exists
//   note <text>\n                                 one per CompiledShader::notes line
//   spirv <word count>\n
//   <the words, native byte order>

struct DiskEntry {
  uint64_t key = 0;
  std::vector<fs::path> dependencies;
  std::vector<std::string> absent;
  std::vector<uint32_t> spirv;
  std::vector<std::string> notes;
};
uint64_t content_hash(std::string_view text);
// The entry for direct_key when every file it lists still hashes the same and nothing has
// appeared where an include was searched before it was found; nothing otherwise (missing,
// unreadable, malformed or stale entries alike).
std::optional<DiskEntry> disk_lookup(const fs::path& dir, uint64_t direct_key);
// Writes the entry through a temporary file renamed into place; false when it could not.
bool disk_store(const fs::path& dir, uint64_t direct_key, const DiskEntry& entry,
                const std::vector<uint64_t>& dependency_hashes);

}  // namespace penumbra::shader::detail
