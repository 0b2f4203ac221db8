#pragma once

// The program registry: the pipelines of a renderer, each with the stage files it was built
// from and every file those include, so a shader edit rebuilds exactly the pipelines that read
// the edited file.
//
// A reload is all or nothing across the programs one change reaches: every one is recompiled
// and its interface checked against the one its pipeline layout, vertex input, attachments and
// dispatch were made for (the SPIR-V given to `add`; shader::interface_changes) before any is
// recreated. A compile error or an interface change in any of them keeps every last good
// pipeline; a creation that fails puts back the ones already recreated.
//
//   shader::ProgramRegistry registry(shader_dir);
//   registry.add("tonemap", {{"render/tonemap.comp", {}}}, [&](const shader::Spirvs& spirv) {
//     tonemap = std::make_unique<gpu::ComputePipeline>(ctx, spirv[0], layout);
//   });
//   auto result = registry.reload({shader_dir / "penumbra/noise.glsl"});

#include <cstdint>
#include <filesystem>
#include <functional>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <set>
#include <string>
#include <vector>

namespace penumbra::shader {

// A stage of a program: a file relative to the registry's shader directory, with its defines.
struct ProgramSource {
  std::string file;
  std::vector<Define> defines;
};

// The SPIR-V of a program's stages, in the order of its sources.
using Spirvs = std::vector<std::vector<uint32_t>>;

// What a reload did: programs rebuilt, programs whose new sources failed, and the errors with
// file:line. When anything failed nothing was rebuilt: `held` lists the programs that compiled
// but keep their last good pipeline because another one failed.
struct ReloadResult {
  std::vector<std::string> rebuilt;
  std::vector<std::string> failed;
  std::vector<std::string> held;
  std::vector<std::string> errors;
  bool ok() const { return failed.empty(); }
};

class ProgramRegistry {
 public:
  using Create = std::function<void(const Spirvs&)>;

  explicit ProgramRegistry(std::filesystem::path shader_dir);

  const std::filesystem::path& shader_dir() const { return shader_dir_; }

  // Compiles the sources and calls create with their SPIR-V; the program is then rebuilt by
  // reload() whenever one of the files it read changes. Throws penumbra::Error (with file:line)
  // when a source does not compile, and whatever create throws.
  void add(std::string name, std::vector<ProgramSource> sources, Create create);

  // Recompiles the programs that read one of these files and recreates them. before_first_create
  // runs once, before the first create (the renderer waits for the GPU to be idle there).
  ReloadResult reload(const std::vector<std::filesystem::path>& changed_files,
                      const std::function<void()>& before_first_create = {});

  // Every file the programs read (stage files and includes), weakly canonical.
  std::vector<std::filesystem::path> files() const;
  // The programs that read `file` (directly or through includes).
  std::vector<std::string> programs_reading(const std::filesystem::path& file) const;
  // Program names in the order they were added.
  std::vector<std::string> names() const;

 private:
  struct Program {
    std::string name;
    std::vector<ProgramSource> sources;
    std::set<std::filesystem::path> dependencies;
    Create create;
    std::vector<Reflection> made_for;  // per stage: the interface the pipeline was made for
    Spirvs current;                    // the SPIR-V of the running pipeline
  };
  Spirvs compile(const std::vector<ProgramSource>& sources,
                 std::set<std::filesystem::path>* dependencies);

  std::filesystem::path shader_dir_;
  Compiler compiler_;
  std::vector<Program> programs_;
};

}  // namespace penumbra::shader
