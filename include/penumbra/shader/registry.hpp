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
//   shader::ProgramRegistry registry(shader_dir);       // or (overlay, {library}): see below
//   registry.add("tonemap", {{"render/tonemap.comp", {}}}, [&](const shader::Spirvs& spirv) {
//     tonemap = std::make_unique<gpu::ComputePipeline>(ctx, spirv[0], layout);
//   });
//   auto result = registry.reload({shader_dir / "penumbra/noise.glsl"});
//
// Latency: a reload compiles the programs it reaches in parallel (one thread each), and makes
// the pipelines of those added with add_prepared in parallel too, while the GPU still runs the
// old ones; it waits for the GPU (before_first_create) only to swap them in.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <set>
#include <string>
#include <vector>

namespace penumbra::shader {

// A stage of a program: a file relative to the registry's shader directories (the first that
// has it), with its defines.
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
  // Of those rebuilt, the programs whose new SPIR-V is the old one's (a comment, or code of a
  // function they do not call): they keep the pipelines they had (nothing is made or swapped).
  std::vector<std::string> same_spirv;
  std::vector<std::string> failed;
  std::vector<std::string> held;
  std::vector<std::string> errors;
  bool ok() const { return failed.empty(); }
};

// A reload's first two steps done (ProgramRegistry::prepare_reload): the programs the change
// reaches compiled and checked, and their new pipelines made; finish_reload swaps them in.
struct PreparedReload {
  struct Program {
    size_t index = 0;  // in the registry's programs, as of `generation`
    Spirvs spirv;
    std::set<std::filesystem::path> deps;
    std::string error;  // a compile error or the interface changes
    std::function<void()> install;
    bool same = false;  // the SPIR-V the running pipelines were made from: they are kept
  };
  std::vector<std::filesystem::path> changed;
  uint64_t generation = 0;  // the registry's programs changed since: prepared again at finish
  std::vector<Program> programs;
};

class ProgramRegistry {
 public:
  // Makes and installs a program's pipelines from its SPIR-V, in one step (with the GPU idle).
  using Create = std::function<void(const Spirvs&)>;
  // Swaps made pipelines in (with the GPU idle); should not throw.
  using Install = std::function<void()>;
  // Makes a program's pipelines and changes nothing else: it may run on a worker thread, next to
  // other programs' Prepare, while the GPU runs the old pipelines. Throws when they cannot be
  // made; what it returns installs them.
  using Prepare = std::function<Install(const Spirvs&)>;

  explicit ProgramRegistry(std::filesystem::path shader_dir);
  // An overlay over libraries: a stage file or an include is read from shader_dir when it is
  // there, else from the first library directory that has it (a user's copy of a few files over
  // the installed library). A file that appears in or disappears from the overlay later counts
  // as a change of the file of the same name: the programs that read it are rebuilt.
  ProgramRegistry(std::filesystem::path shader_dir,
                  std::vector<std::filesystem::path> library_dirs);

  const std::filesystem::path& shader_dir() const { return shader_dir_; }
  // shader_dir, then the library directories: where files are looked up, in order.
  const std::vector<std::filesystem::path>& search_path() const { return search_path_; }
  // The file a relative name reads now: the first directory of the search path that has it
  // (shader_dir / name when none does, for the error to name).
  std::filesystem::path resolve(const std::string& name) const;
  // The name of a file relative to the search path's directory that holds it (weakly
  // canonical), or empty when it lies in none: files of one name in different layers are one.
  std::string layered_name(const std::filesystem::path& file) const;

  // Compiles the sources and calls create with their SPIR-V; the program is then rebuilt by
  // reload() whenever one of the files it read changes. Throws penumbra::Error (with file:line)
  // when a source does not compile, and whatever create throws.
  void add(std::string name, std::vector<ProgramSource> sources, Create create);
  // The same, in two steps: at a reload the pipelines are made in parallel with the other
  // programs' and installed together.
  void add_prepared(std::string name, std::vector<ProgramSource> sources, Prepare prepare);

  // Forgets the program of this name: reloads no longer rebuild it (its pipelines stay with
  // whoever holds them). A renderer that swaps one variant of a program for another (the
  // resolves, when the scene's filters change) adds the new one, then removes the old.
  void remove(const std::string& name);

  // Recompiles the programs that read one of these files and recreates them. before_first_create
  // runs once, before the first create (the renderer waits for the GPU to be idle there).
  ReloadResult reload(const std::vector<std::filesystem::path>& changed_files,
                      const std::function<void()>& before_first_create = {});
  // The same in two steps, for a caller that compiles while the GPU renders a frame:
  // prepare_reload compiles, checks and makes the new pipelines and changes nothing (it may run
  // on another thread, while nothing calls a non-const member of this registry);
  // finish_reload swaps them in, or keeps every last good one when one failed.
  PreparedReload prepare_reload(const std::vector<std::filesystem::path>& changed_files) const;
  ReloadResult finish_reload(PreparedReload prepared,
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
    Prepare prepare;
    std::vector<Reflection> made_for;  // per stage: the interface the pipeline was made for
    Spirvs current;                    // the SPIR-V of the running pipeline
  };
  Spirvs compile(const std::vector<ProgramSource>& sources,
                 std::set<std::filesystem::path>* dependencies) const;
  // What in a recompiled program's interface differs from what its pipeline was made for, each
  // with the file:line of the declaration, as one message; empty when nothing does.
  std::string interface_report(const Program& p, const Spirvs& spirv,
                               const std::set<std::filesystem::path>& deps) const;

  bool reads(const Program& p, const std::set<std::filesystem::path>& files,
             const std::set<std::string>& names) const;

  std::filesystem::path shader_dir_;
  std::vector<std::filesystem::path> search_path_;  // weakly canonical
  mutable Compiler compiler_;  // its cache is its own to guard (programs compile in parallel)
  std::vector<Program> programs_;
  uint64_t generation_ = 0;  // counts the changes of programs_ (add, remove)
};

}  // namespace penumbra::shader
