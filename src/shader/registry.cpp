#include <algorithm>
#include <cctype>
#include <fstream>
#include <functional>
#include <thread>
#include <penumbra/core/error.hpp>
#include <penumbra/shader/registry.hpp>

namespace penumbra::shader {
namespace fs = std::filesystem;

ProgramRegistry::ProgramRegistry(fs::path shader_dir) : ProgramRegistry(std::move(shader_dir), {}) {}

ProgramRegistry::ProgramRegistry(fs::path shader_dir, std::vector<fs::path> library_dirs)
    : shader_dir_(std::move(shader_dir)),
      search_path_([&] {
        std::vector<fs::path> dirs{shader_dir_}, path;
        dirs.insert(dirs.end(), library_dirs.begin(), library_dirs.end());
        for (const fs::path& d : dirs) {
          std::error_code ec;
          fs::path c = fs::weakly_canonical(d, ec);
          if (ec || c.empty()) c = d;
          if (std::find(path.begin(), path.end(), c) == path.end()) path.push_back(c);
        }
        return path;
      }()),
      compiler_([this] {
        CompileOptions o;
        o.include_dirs = search_path_;
        o.overlay_include_dirs = true;
        o.disk_cache_dir = default_disk_cache_dir();
        return o;
      }()) {}

fs::path ProgramRegistry::resolve(const std::string& name) const {
  for (const fs::path& dir : search_path_) {
    std::error_code ec;
    if (fs::exists(dir / name, ec)) return dir / name;
  }
  return shader_dir_ / name;
}

std::string ProgramRegistry::layered_name(const fs::path& file) const {
  std::error_code ec;
  const fs::path f = fs::weakly_canonical(fs::absolute(file, ec), ec);
  for (const fs::path& dir : search_path_) {
    const fs::path rel = f.lexically_relative(dir);
    if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
  }
  return {};
}

bool ProgramRegistry::reads(const Program& p, const std::set<fs::path>& files,
                            const std::set<std::string>& names) const {
  for (const fs::path& dep : p.dependencies) {
    if (files.count(dep)) return true;
    if (!names.empty() && search_path_.size() > 1 && names.count(layered_name(dep))) return true;
  }
  return false;
}

Spirvs ProgramRegistry::compile(const std::vector<ProgramSource>& sources,
                                std::set<fs::path>* dependencies) const {
  Spirvs out;
  for (const auto& src : sources) {
    auto c = compiler_.compile_file(resolve(src.file), std::nullopt, src.defines);
    if (dependencies)
      for (const auto& d : c.dependencies) dependencies->insert(fs::weakly_canonical(d));
    out.push_back(std::move(c.spirv));
  }
  return out;
}

void ProgramRegistry::add(std::string name, std::vector<ProgramSource> sources, Create create) {
  // One step: everything happens in the install, which the registry calls with the GPU idle.
  add_prepared(std::move(name), std::move(sources), [create](const Spirvs& spirv) -> Install {
    return [create, spirv] { create(spirv); };
  });
}

void ProgramRegistry::add_prepared(std::string name, std::vector<ProgramSource> sources,
                                   Prepare prepare) {
  Program p{std::move(name), std::move(sources), {}, std::move(prepare), {}, {}};
  Spirvs spirv = compile(p.sources, &p.dependencies);
  for (const auto& stage : spirv) p.made_for.push_back(reflect(stage));
  p.prepare(spirv)();
  p.current = std::move(spirv);
  programs_.push_back(std::move(p));
  ++generation_;
}

namespace {

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The first line of `files` that mentions `word` as a whole word on a declaration-looking line
// (`type word;`, or a line with `layout`, `struct`, `uniform` or `buffer`), as "file:line".
std::string declaration_of(const std::string& word, const std::vector<fs::path>& files) {
  if (word.empty()) return {};
  for (const fs::path& f : files) {
    std::ifstream in(f);
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      for (size_t at = line.find(word); at != std::string::npos; at = line.find(word, at + 1)) {
        const bool starts = at == 0 || !is_word_char(line[at - 1]);
        const bool ends = at + word.size() >= line.size() || !is_word_char(line[at + word.size()]);
        if (!starts || !ends) continue;
        // `type name;` / `type name[N];` (a member or variable), or a line that declares a
        // resource or a struct; not a use such as `frame.name.x`.
        size_t b = at;
        while (b > 0 && (line[b - 1] == ' ' || line[b - 1] == '\t')) --b;
        const bool after_type = b < at && b > 0 && is_word_char(line[b - 1]);
        size_t e = at + word.size();
        while (e < line.size() && line[e] != ';' && line[e] != '=' && line[e] != '(' &&
               line[e] != '.')
          ++e;
        const bool ends_declaration = e < line.size() && line[e] == ';';
        const bool declares = (after_type && ends_declaration) ||
                              line.find("layout") != std::string::npos ||
                              line.find("struct") != std::string::npos ||
                              line.find("uniform") != std::string::npos ||
                              line.find("buffer") != std::string::npos;
        if (declares) return f.string() + ":" + std::to_string(n);
        break;
      }
    }
  }
  return {};
}

// The quoted names in an interface_changes() line ('name'; in "was 'a', is now 'b'" the new one
// is last), or the last part of the dotted member path it starts with: what to look for.
std::vector<std::string> names_in(const std::string& change) {
  std::vector<std::string> names;
  for (size_t q = change.find('\''); q != std::string::npos;) {
    const size_t end = change.find('\'', q + 1);
    if (end == std::string::npos) break;
    names.push_back(change.substr(q + 1, end - q - 1));
    q = change.find('\'', end + 1);
  }
  const size_t space = change.find(' ');
  const std::string head = change.substr(0, space);
  if (const size_t dot = head.rfind('.'); dot != std::string::npos && names.empty())
    names.push_back(head.substr(dot + 1));
  return names;
}

// Runs body(0) ... body(n - 1), one thread each beyond the first (n is the number of programs
// one edit reaches: a handful). Every body catches its own errors.
void parallel_for(size_t n, const std::function<void(size_t)>& body) {
  std::vector<std::thread> threads;
  threads.reserve(n > 0 ? n - 1 : 0);
  for (size_t i = 1; i < n; ++i) threads.emplace_back(body, i);
  if (n > 0) body(0);
  for (auto& t : threads) t.join();
}

}  // namespace

std::string ProgramRegistry::interface_report(const Program& p, const Spirvs& spirv,
                                              const std::set<fs::path>& deps) const {
  std::vector<std::string> changes;
  const std::vector<fs::path> read(deps.begin(), deps.end());
  for (size_t stage = 0; stage < spirv.size() && stage < p.made_for.size(); ++stage) {
    std::vector<std::string> stage_changes;
    try {
      stage_changes = interface_changes(p.made_for[stage], reflect(spirv[stage]));
    } catch (const Error& e) {
      stage_changes = {e.what()};
    }
    const fs::path stage_file = resolve(p.sources[stage].file);
    for (const std::string& c : stage_changes) {
      std::string where;
      const std::vector<std::string> names = names_in(c);
      for (auto name = names.rbegin(); name != names.rend(); ++name) {  // the new one last
        // The stage file first, then what it includes.
        std::vector<fs::path> order{stage_file};
        order.insert(order.end(), read.begin(), read.end());
        where = declaration_of(*name, order);
        if (!where.empty()) break;
      }
      changes.push_back((where.empty() ? stage_file.string() : where) + ": " + c);
    }
  }
  if (changes.empty()) return {};
  std::string message = "program '" + p.name +
                        "': the edit changes the interface its pipeline was made for (the "
                        "pipeline layout, vertex input, attachments and dispatch stay as built):";
  for (const std::string& c : changes) message += "\n  " + c;
  return message;
}

ReloadResult ProgramRegistry::reload(const std::vector<fs::path>& changed_files,
                                     const std::function<void()>& before_first_create) {
  return finish_reload(prepare_reload(changed_files), before_first_create);
}

PreparedReload ProgramRegistry::prepare_reload(const std::vector<fs::path>& changed_files) const {
  PreparedReload prepared;
  prepared.changed = changed_files;
  prepared.generation = generation_;
  // Each changed file as the dependencies name it (canonical), and as it was written: a file
  // that became a symlink (to /dev/zero, say) canonicalizes elsewhere, yet the programs that
  // read it must see the change and report it.
  std::set<fs::path> files;
  std::set<std::string> names;  // with libraries: the changed files' names in the layers
  for (const auto& f : changed_files) {
    std::error_code ec;
    files.insert(fs::weakly_canonical(f));
    files.insert(fs::absolute(f, ec).lexically_normal());
    if (search_path_.size() > 1)
      if (std::string name = layered_name(f); !name.empty()) names.insert(std::move(name));
  }

  // 1. Recompile and check every program the change reaches, in parallel; create nothing yet.
  auto& pending = prepared.programs;
  for (size_t i = 0; i < programs_.size(); ++i)
    if (reads(programs_[i], files, names)) pending.push_back({i, {}, {}, {}, {}, false});
  parallel_for(pending.size(), [&](size_t i) {
    PreparedReload::Program& next = pending[i];
    const Program& p = programs_[next.index];
    try {
      next.spirv = compile(p.sources, &next.deps);
      next.same = next.spirv == p.current;
      next.error = interface_report(p, next.spirv, next.deps);
    } catch (const std::exception& e) {  // a compile error, or a stage file that cannot be read
      next.error = e.what();
    }
  });
  // 2. Make the pipelines of the programs that compiled and kept their interface, in parallel.
  // A program whose SPIR-V did not change (a comment, or code it does not call) keeps its
  // pipelines: they are what the new code would make, and the driver is not asked again (on
  // lavapipe that costs a compile at the next use even when its cache answers).
  const bool compiled =
      std::all_of(pending.begin(), pending.end(),
                  [](const PreparedReload::Program& n) { return n.error.empty(); });
  if (compiled) {
    parallel_for(pending.size(), [&](size_t i) {
      PreparedReload::Program& next = pending[i];
      if (next.same) {
        next.install = [] {};
        return;
      }
      try {
        next.install = programs_[next.index].prepare(next.spirv);
      } catch (const std::exception& e) {
        next.error = e.what();
      }
    });
  }
  return prepared;
}

ReloadResult ProgramRegistry::finish_reload(PreparedReload prepared,
                                            const std::function<void()>& before_first_create) {
  // Programs added or removed since (a variant swapped in): what was prepared may name others.
  if (prepared.generation != generation_) prepared = prepare_reload(prepared.changed);
  ReloadResult result;
  auto& pending = prepared.programs;
  for (const auto& n : pending) {
    if (n.error.empty()) continue;
    result.failed.push_back(programs_[n.index].name);
    result.errors.push_back(n.error);
  }
  if (!result.failed.empty()) {
    // All or nothing: every last good pipeline stays; what was made is dropped unused.
    for (const auto& n : pending)
      if (n.error.empty()) result.held.push_back(programs_[n.index].name);
    return result;
  }

  // 3. Swap them all in (the GPU idle); if an install fails, put back those already installed.
  const bool any_new = std::any_of(pending.begin(), pending.end(),
                                   [](const PreparedReload::Program& n) { return !n.same; });
  if (any_new && before_first_create) before_first_create();
  for (size_t i = 0; i < pending.size(); ++i) {
    Program& p = programs_[pending[i].index];
    try {
      pending[i].install();
    } catch (const Error& e) {
      result.failed.push_back(p.name);
      result.errors.push_back(e.what());
      for (size_t k = 0; k < i; ++k) {
        Program& done = programs_[pending[k].index];
        try {
          if (!pending[k].same) done.prepare(done.current)();  // a kept one is still in place
          result.held.push_back(done.name);
        } catch (const Error& again) {
          result.failed.push_back(done.name);
          result.errors.push_back("putting back the last good '" + done.name +
                                  "' failed: " + again.what());
        }
      }
      for (size_t k = i + 1; k < pending.size(); ++k)
        result.held.push_back(programs_[pending[k].index].name);
      return result;
    }
  }
  for (auto& n : pending) {
    Program& p = programs_[n.index];
    if (n.same) result.same_spirv.push_back(p.name);
    p.current = std::move(n.spirv);
    p.dependencies = std::move(n.deps);
    result.rebuilt.push_back(p.name);
  }
  return result;
}

std::vector<fs::path> ProgramRegistry::files() const {
  std::set<fs::path> all;
  for (const auto& p : programs_) all.insert(p.dependencies.begin(), p.dependencies.end());
  return {all.begin(), all.end()};
}

std::vector<std::string> ProgramRegistry::programs_reading(const fs::path& file) const {
  const std::set<fs::path> files{fs::weakly_canonical(file)};
  std::set<std::string> names;
  if (search_path_.size() > 1)
    if (std::string name = layered_name(file); !name.empty()) names.insert(std::move(name));
  std::vector<std::string> out;
  for (const auto& p : programs_)
    if (reads(p, files, names)) out.push_back(p.name);
  return out;
}

void ProgramRegistry::remove(const std::string& name) {
  std::erase_if(programs_, [&](const Program& p) { return p.name == name; });
  ++generation_;
}

std::vector<std::string> ProgramRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& p : programs_) out.push_back(p.name);
  return out;
}

}  // namespace penumbra::shader
