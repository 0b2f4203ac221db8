#include <algorithm>
#include <penumbra/core/error.hpp>
#include <penumbra/shader/registry.hpp>

namespace penumbra::shader {
namespace fs = std::filesystem;

ProgramRegistry::ProgramRegistry(fs::path shader_dir)
    : shader_dir_(std::move(shader_dir)), compiler_([this] {
        CompileOptions o;
        o.include_dirs = {shader_dir_};
        o.disk_cache_dir = default_disk_cache_dir();
        return o;
      }()) {}

Spirvs ProgramRegistry::compile(const std::vector<ProgramSource>& sources,
                                std::set<fs::path>* dependencies) {
  Spirvs out;
  for (const auto& src : sources) {
    auto c = compiler_.compile_file(shader_dir_ / src.file, std::nullopt, src.defines);
    if (dependencies)
      for (const auto& d : c.dependencies) dependencies->insert(fs::weakly_canonical(d));
    out.push_back(std::move(c.spirv));
  }
  return out;
}

void ProgramRegistry::add(std::string name, std::vector<ProgramSource> sources, Create create) {
  Program p{std::move(name), std::move(sources), {}, std::move(create)};
  p.create(compile(p.sources, &p.dependencies));
  programs_.push_back(std::move(p));
}

ReloadResult ProgramRegistry::reload(const std::vector<fs::path>& changed_files,
                                     const std::function<void()>& before_first_create) {
  ReloadResult result;
  std::set<fs::path> files;
  for (const auto& f : changed_files) files.insert(fs::weakly_canonical(f));
  bool first = true;
  for (auto& p : programs_) {
    const bool affected = std::any_of(files.begin(), files.end(), [&](const fs::path& f) {
      return p.dependencies.count(f) > 0;
    });
    if (!affected) continue;
    std::set<fs::path> deps;
    Spirvs spirv;
    try {
      spirv = compile(p.sources, &deps);
    } catch (const Error& e) {  // a compile error, or a stage file that cannot be read
      result.failed.push_back(p.name);
      result.errors.push_back(e.what());
      continue;  // the last good pipeline stays
    }
    if (first && before_first_create) before_first_create();
    first = false;
    try {
      p.create(spirv);
    } catch (const Error& e) {
      result.failed.push_back(p.name);
      result.errors.push_back(e.what());
      continue;
    }
    p.dependencies = std::move(deps);
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
  const fs::path f = fs::weakly_canonical(file);
  std::vector<std::string> out;
  for (const auto& p : programs_)
    if (p.dependencies.count(f)) out.push_back(p.name);
  return out;
}

std::vector<std::string> ProgramRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& p : programs_) out.push_back(p.name);
  return out;
}

}  // namespace penumbra::shader
