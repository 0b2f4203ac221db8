// A seeded fuzzer of the shipped scenes and of shader edits, bounded in time: every mutated
// scene either loads (and then builds and renders a small frame) or fails with an error that
// names file:line or key = value; every shader edit either reloads or fails naming file:line;
// nothing crashes, no case runs past its bound (a watchdog aborts naming it), the validation
// layer stays silent, and after every edit is undone the image equals a cold start bit for bit.
//
// PENUMBRA_FUZZ_SEED (default 1) picks the cases, PENUMBRA_FUZZ_SECONDS (default 45) bounds each
// of the two parts. A failure prints the seed and the case: rerun with the same seed to repeat.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "script.hpp"
#include "temp_tree.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::GpuTest;
using testing::TempTree;

uint64_t env_number(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

// Aborts the process, naming the case, when one case runs longer than its bound.
class Watchdog {
 public:
  explicit Watchdog(std::chrono::seconds bound) : bound_(bound), thread_([this] { run(); }) {}
  ~Watchdog() {
    {
      std::lock_guard l(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void start(std::string what) {
    std::lock_guard l(m_);
    what_ = std::move(what);
    started_ = Clock::now();
    armed_ = true;
  }
  void done() {
    std::lock_guard l(m_);
    armed_ = false;
  }

 private:
  void run() {
    std::unique_lock l(m_);
    while (!stop_) {
      cv_.wait_for(l, std::chrono::milliseconds(200));
      if (armed_ && Clock::now() - started_ > bound_) {
        std::fprintf(stderr, "fuzz: a case ran past %lld s (a hang): %s\n",
                     static_cast<long long>(bound_.count()), what_.c_str());
        std::fflush(stderr);
        std::abort();
      }
    }
  }
  std::chrono::seconds bound_;
  std::mutex m_;
  std::condition_variable cv_;
  std::string what_;
  Clock::time_point started_;
  bool armed_ = false, stop_ = false;
  std::thread thread_;
};

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}
std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

// An error a user can act on: it names the file and line, or the key and the value (or, for a
// property of the whole scene such as "no geometry", or a stage that links without main(), the
// file: there is no line to name).
bool names_a_place(const std::string& e) {
  // (std::regex is avoided here: GCC 12 warns inside it under the sanitizer build.)
  const auto digit_at = [&](size_t i) { return i < e.size() && std::isdigit(uint8_t(e[i])); };
  for (const char* ext : {".toml:", ".glsl:", ".comp:", ".vert:", ".frag:"}) {
    for (size_t at = e.find(ext); at != std::string::npos; at = e.find(ext, at + 1)) {
      if (digit_at(at + std::strlen(ext))) return true;  // file:line
    }
  }
  for (const char* whole : {".toml: the scene ", ".comp: error: Linking", ".vert: error: Linking",
                            ".frag: error: Linking", "render size "}) {
    if (e.find(whole) != std::string::npos) return true;
  }
  // key = value: "section.key = " or "[[table]] key = ".
  for (size_t at = e.find(" = "); at != std::string::npos; at = e.find(" = ", at + 1)) {
    size_t b = at;
    while (b > 0 && (std::islower(uint8_t(e[b - 1])) || std::isdigit(uint8_t(e[b - 1])) ||
                     e[b - 1] == '_' || e[b - 1] == '.'))
      --b;
    const std::string key = e.substr(b, at - b);
    if (key.empty()) continue;
    if (key.find('.') != std::string::npos) return true;
    if (b >= 2 && e[b - 1] == ' ' && e[b - 2] == ']') return true;
  }
  return false;
}

const std::vector<std::string> kValues{"1e39",
                                       "-1e39",
                                       "1e-50",
                                       "0",
                                       "-1",
                                       "1e30",
                                       "nan",
                                       "inf",
                                       "65536",
                                       "-0",
                                       "16384",
                                       "8192",
                                       "2",
                                       "3",
                                       "1e9",
                                       "4294967296",
                                       "9223372036854775807",
                                       "\"x\"",
                                       "\"\"",
                                       "true",
                                       "[1,2]",
                                       "[1e39, 0, 0]",
                                       "[0, 0, 0]",
                                       "[]",
                                       "{}",
                                       "0.0001"};

// Path-valued keys ("file:" meshes, mask textures) and what each hostile value must be called.
struct HostilePath {
  std::string toml;  // the value as the scene file writes it (inside the quotes)
  std::string says;
};
const std::vector<HostilePath> kHostilePaths{
    {"x.png\\u0000.obj", "'x.png\\0.obj' contains a NUL byte (at 5)"},
    {"/dev/zero", "'/dev/zero' is a character device, not a regular file"},
    {"/", "'/' is a directory, not a file"},
    {"no/such/file.obj", "'no/such/file.obj' not found"},
};

std::string mutate_scene(std::string text, std::mt19937_64& rng) {
  auto pick = [&](size_t n) { return size_t(rng() % std::max<size_t>(n, 1)); };
  const int count = 1 + int(rng() % 3);
  for (int m = 0; m < count; ++m) {
    std::vector<std::string> lines = lines_of(text);
    if (lines.empty()) break;
    const size_t i = pick(lines.size());
    switch (rng() % 8) {
      case 7: {  // a path-valued key given a hostile path (kHostilePaths)
        for (size_t k = 0; k < lines.size(); ++k) {
          std::string& l = lines[(i + k) % lines.size()];
          const bool mesh = l.rfind("mesh = ", 0) == 0;
          if (!mesh && l.rfind("mask_texture = ", 0) != 0) continue;
          const std::string& path = kHostilePaths[pick(kHostilePaths.size())].toml;
          l = l.substr(0, l.find(" = ") + 3) + "\"" + (mesh ? "file:" : "") + path + "\"";
          break;
        }
        break;
      }
      case 0:
      case 1: {  // a value
        const size_t eq = lines[i].find(" = ");
        if (eq != std::string::npos)
          lines[i] = lines[i].substr(0, eq + 3) + kValues[pick(kValues.size())];
        break;
      }
      case 2:  // a line removed
        lines.erase(lines.begin() + long(i));
        break;
      case 3:  // a line doubled
        lines.insert(lines.begin() + long(i), lines[i]);
        break;
      case 4:  // a typo in a key
        if (!lines[i].empty() && lines[i].find(" = ") != std::string::npos)
          lines[i][pick(lines[i].find(" = "))] = char('a' + pick(26));
        break;
      case 5: {  // a table repeated (a third light, a second sun)
        size_t start = i;
        while (start > 0 && (lines[start].empty() || lines[start][0] != '[')) --start;
        size_t end = start + 1;
        while (end < lines.size() && (lines[end].empty() || lines[end][0] != '[')) ++end;
        std::vector<std::string> block(lines.begin() + long(start), lines.begin() + long(end));
        for (int k = 0; k < 2; ++k) lines.insert(lines.end(), block.begin(), block.end());
        break;
      }
      default:  // cut short
        text = joined(lines).substr(0, pick(text.size()));
        continue;
    }
    text = joined(lines);
  }
  return text;
}

class Fuzz : public GpuTest {};

TEST_F(Fuzz, MutatedScenesLoadOrFailNamingFileLineOrKey) {
  const uint64_t seed = env_number("PENUMBRA_FUZZ_SEED", 1);
  const auto budget = std::chrono::seconds(env_number("PENUMBRA_FUZZ_SECONDS", 45));
  std::mt19937_64 rng(seed);
  Watchdog watchdog(std::chrono::seconds(120));
  const std::vector<std::string> scenes{"default", "grazing", "indoor", "space"};
  std::vector<std::pair<std::string, std::string>> originals;
  for (const auto& s : scenes) {
    const fs::path file = scene::find_scene(s);
    originals.emplace_back(file.string(), testing::read_text(file));
  }
  const auto end = Clock::now() + budget;
  int cases = 0, loaded = 0, rendered = 0, refused = 0;
  while (Clock::now() < end) {
    const auto& [file, text] = originals[size_t(rng() % originals.size())];
    const std::string mutated = mutate_scene(text, rng);
    const std::string what = "seed " + std::to_string(seed) + ", case " + std::to_string(cases) +
                             " (mutated " + file + "):\n" + mutated;
    ++cases;
    watchdog.start(what);
    try {
      scene::Scene s =
          scene::parse_scene(mutated, fs::path(file).filename(), fs::path(file).parent_path());
      ++loaded;
      // One in eight scenes that load is built and rendered small (building is the slow part).
      if (rng() % 8 == 0) {
        render::RendererOptions o;
        o.width = 64;
        o.height = 36;
        render::Renderer r(ctx(), s, o);
        r.render(0);
        ++rendered;
      }
    } catch (const Error& e) {
      ++refused;
      EXPECT_TRUE(names_a_place(e.what()))
          << "an error that names no file:line or key = value: " << e.what() << "\n"
          << what;
    }
    watchdog.done();
    const auto messages = ctx().validation_sink().take();
    for (const auto& m : messages) ADD_FAILURE() << gpu::to_string(m) << "\n" << what;
    if (::testing::Test::HasFailure()) break;  // one case to look at, not a flood
  }
  std::printf("[fuzz] scenes: seed %llu, %d cases in %lld s: %d loaded (%d rendered), %d refused\n",
              static_cast<unsigned long long>(seed), cases, static_cast<long long>(budget.count()),
              loaded, rendered, refused);
  EXPECT_GT(cases, 20);
  EXPECT_GT(refused, 0);
  EXPECT_GT(loaded, 0);
}

// ---------------------------------------------------------------------------------------------
// The seeded corpus: one case of every class of hostile input, on every shipped scene, run
// whatever the seed. Each must be refused with the right message at the line of the key that is
// wrong (not merely "some file:line"): a path holding a NUL byte, a path to something that is no
// regular file, the checks that span two keys, and every script command whose target is missing.

// text with `key = value` in the first table headed `header` ("[camera]", "[[spot]]"): the
// key's line replaced when the table has it, else a line added under the header. Returns the
// text and the key's line (1-based).
std::pair<std::string, int> with_key(const std::string& text, const std::string& header,
                                     const std::string& key, const std::string& value) {
  std::vector<std::string> lines = lines_of(text);
  size_t h = 0;
  while (h < lines.size() && lines[h].rfind(header, 0) != 0) ++h;
  if (h == lines.size()) {
    lines.push_back(header);
    lines.push_back(key + " = " + value);
    return {joined(lines), int(lines.size())};
  }
  for (size_t i = h + 1; i < lines.size() && (lines[i].empty() || lines[i][0] != '['); ++i) {
    if (lines[i].rfind(key + " =", 0) == 0) {
      lines[i] = key + " = " + value;
      return {joined(lines), int(i + 1)};
    }
  }
  lines.insert(lines.begin() + long(h + 1), key + " = " + value);
  return {joined(lines), int(h + 2)};
}

// The value text of `key` in the first table headed `header` (without a trailing comment).
std::string value_of(const std::string& text, const std::string& header, const std::string& key) {
  const std::vector<std::string> lines = lines_of(text);
  size_t h = 0;
  while (h < lines.size() && lines[h].rfind(header, 0) != 0) ++h;
  for (size_t i = h + 1; i < lines.size() && (lines[i].empty() || lines[i][0] != '['); ++i) {
    if (lines[i].rfind(key + " = ", 0) != 0) continue;
    const std::string v = lines[i].substr(key.size() + 3);
    return v.substr(0, v.find('#'));
  }
  return {};
}

// What parsing `text` as the shipped scene `file` throws ("" when it loads).
std::string scene_error(const std::string& text, const fs::path& file) {
  try {
    scene::parse_scene(text, file.filename(), file.parent_path());
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

TEST_F(Fuzz, SeededCorpusEveryHostileClassIsNamedAtTheLineOfTheWrongKey) {
  int cases = 0;
  for (const std::string name : {"default", "grazing", "indoor", "space"}) {
    const fs::path file = scene::find_scene(name);
    const std::string text = testing::read_text(file);
    const std::string at = file.filename().string() + ":";
    // 1. Every path-valued key of the scene, and one added where it has none, with each
    // hostile path.
    std::vector<std::pair<std::string, std::string>> keys;  // header, key
    std::vector<std::string> lines = lines_of(text);
    for (const std::string& l : lines) {
      if (l.rfind("mask_texture = ", 0) == 0) keys.emplace_back("[[material]]", "mask_texture");
    }
    keys.emplace_back("[[object]]", "mesh");
    if (keys.size() == 1) keys.emplace_back("[[material]]", "mask_texture");
    for (const auto& [header, key] : keys) {
      for (const HostilePath& h : kHostilePaths) {
        // A mask texture needs mask = "texture" to be read; a mesh the "file:" prefix.
        std::string edited = text;
        if (key == "mask_texture") edited = with_key(edited, header, "mask", "\"texture\"").first;
        const auto [t, line] =
            with_key(edited, header, key,
                     std::string("\"") + (key == "mesh" ? "file:" : "") + h.toml + "\"");
        const std::string e = scene_error(t, file);
        EXPECT_THAT(e, ::testing::HasSubstr(at + std::to_string(line) + ": "))
            << name << " " << header << " " << key << " = " << h.toml;
        EXPECT_THAT(e, ::testing::HasSubstr(h.says)) << name << " " << key << " = " << h.toml;
        ++cases;
      }
    }
    // 2. The checks that span keys, at the line of the key the case makes wrong: set in the
    // scene's own table, or in a table added at the end (whose `key` line is the one to name).
    struct Cross {
      std::string header, key, value, says;
    };
    std::vector<Cross> cross{
        {"[camera]", "near", "1e38", "must be less than far"},
        {"[camera]", "target", value_of(text, "[camera]", "position"),
         "the camera's target equals its position"},
        {"[shadows]", "pcss_min_filter_texels", "100", "must not exceed pcss_max_filter_texels"},
        {"[[material]]\nname = \"fuzz_m\"", "alpha", "\"masked\"", "needs a mask"},
        {"[[material]]\nname = \"fuzz_m\"", "mask", "\"texture\"", "needs a mask_texture file"},
        {"[[object]]\nmesh = \"sphere\"\nscale = [1, 2, 1]", "analytic_shadow", "true",
         "needs a uniform scale"},
    };
    if (text.find("[[spot]]") != std::string::npos) {
      cross.push_back({"[[spot]]", "target", value_of(text, "[[spot]]", "position"),
                       "equals the light's position"});
      cross.push_back({"[[spot]]", "inner_angle", "89", "must not exceed"});
    }
    for (const Cross& c : cross) {
      std::string edited;
      int line = 0;
      if (c.header.find('\n') != std::string::npos) {  // a table of its own, appended
        edited = text + c.header + "\n" + c.key + " = " + c.value + "\n";
        line = int(lines_of(edited).size());
      } else {
        std::tie(edited, line) = with_key(text, c.header, c.key, c.value);
      }
      const std::string e = scene_error(edited, file);
      EXPECT_THAT(e, ::testing::HasSubstr(at + std::to_string(line) + ": "))
          << name << " " << c.header << " " << c.key << " = " << c.value;
      EXPECT_THAT(e, ::testing::HasSubstr(c.says)) << name << " " << c.key << " = " << c.value;
      ++cases;
    }
  }
  // 3. A scene file that is no regular file.
  for (const auto& [path, says] : std::vector<std::pair<std::string, std::string>>{
           {"/dev/null", "is a character device, not a regular file"},
           {"/", "is a directory, not a file"},
           {"/no/such/scene.toml", "not found"}}) {
    try {
      scene::load_scene(path);
      ADD_FAILURE() << path << " loaded as a scene";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr("scene file '" + path + "' " + says));
    }
    ++cases;
  }
  std::printf("[fuzz] seeded corpus: %d hostile scene cases\n", cases);
}

// Every script command whose target is missing (or is no file) fails naming the script's line,
// the command and the target; penumbra-view exits non-zero on such an error (script_tests).
TEST_F(Fuzz, SeededCorpusEveryScriptCommandWithAMissingTargetFailsAtItsLine) {
  TempTree tree(true);
  const std::string pcf = (tree.shaders() / "penumbra/pcf.glsl").string();
  const std::vector<std::pair<std::string, std::string>> corpus{
      {"scene /no/such/scene.toml", "scene file '/no/such/scene.toml' not found"},
      {"scene /dev/null", "scene file '/dev/null' is a character device, not a regular file"},
      {"scene /", "scene file '/' is a directory, not a file"},
      {"scene no_such_scene", "scene 'no_such_scene' not found"},
      {"reload no/such.glsl", "does not exist, and no pipeline reads it"},
      {"reload /dev/zero", "is a character device, not a regular file, and no pipeline reads it"},
      {"edit no/such.glsl 50", "no edit of " + (tree.shaders() / "no/such.glsl").string()},
      {"replace no/such.glsl a b 50",
       "replace: " + (tree.shaders() / "no/such.glsl").string() + " not found"},
      {"replace /dev/zero a b 50", "replace: /dev/zero is a character device"},
      {"replace penumbra/pcf.glsl \"no such text\" x 50", "does not occur in " + pcf},
      {"get no.such", "get: unknown parameter 'no.such'"},
      {"set no.such 1", "set: unknown parameter 'no.such'"},
      {"view no_such_view", "render.view no_such_view: expected one of"},
      {"screenshot /dev/null/x.png",
       "/dev/null/x.png: cannot create the directory /dev/null: Not a directory"},
      {"expect_rebuilt no-such-pipeline", "no reload happened"},
      {"reload penumbra/pcf.glsl\nexpect_rebuilt no-such-pipeline", "no-such-pipeline"},
      {"expect_reload_error no_such_text", "no_such_text"},
      {std::string("reload a\0b.glsl", 15), "'reload a\\0b.glsl' holds a NUL byte (column 9)"},
  };
  for (const auto& [commands, says] : corpus) {
    runtime::ScriptSetup setup;
    setup.session.shader_dir = tree.shaders();
    setup.session.width = 64;
    setup.session.height = 36;
    setup.session.log = [](const std::string&) {};
    setup.timeout = std::chrono::milliseconds(50);
    runtime::Script script(ctx(), setup);
    std::istringstream in(commands);
    const size_t line = size_t(std::count(commands.begin(), commands.end(), '\n')) + 1;
    try {
      script.run(in, "corpus.txt");
      ADD_FAILURE() << "no error for: " << commands;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr("corpus.txt:" + std::to_string(line) + ": "))
          << commands;
      EXPECT_THAT(e.what(), ::testing::HasSubstr(says)) << commands;
    }
    const auto messages = ctx().validation_sink().take();
    for (const auto& m : messages) ADD_FAILURE() << gpu::to_string(m) << "\n" << commands;
  }
}

// One random edit of a shader file the renderer reads.
std::string mutate_shader(const std::string& text, std::mt19937_64& rng) {
  std::vector<std::string> lines = lines_of(text);
  if (lines.empty()) return "garbage";
  auto pick = [&](size_t n) { return size_t(rng() % std::max<size_t>(n, 1)); };
  const size_t i = pick(lines.size());
  switch (rng() % 8) {
    case 0:
      lines.erase(lines.begin() + long(i));
      break;
    case 1:
      lines.insert(lines.begin() + long(i), lines[i]);
      break;
    case 2:
      lines.insert(lines.begin() + long(i), "%% not glsl %%");
      break;
    case 3:
      return text.substr(0, pick(text.size()));  // a half-written save
    case 4: {                                    // a binding or set moved
      for (const char* key : {"binding = ", "set = ", "location = "}) {
        const size_t at = text.find(key, pick(text.size()));
        if (at == std::string::npos) continue;
        std::string t = text;
        t.replace(at + std::string(key).size(), 1, std::to_string(pick(12)));
        return t;
      }
      break;
    }
    case 5: {  // a number changed (the first d.d in the line)
      std::string& l = lines[i];
      for (size_t k = 0; k + 2 < l.size(); ++k) {
        if (!std::isdigit(uint8_t(l[k])) || l[k + 1] != '.' || !std::isdigit(uint8_t(l[k + 2])))
          continue;
        size_t b = k, e = k + 2;
        while (b > 0 && std::isdigit(uint8_t(l[b - 1]))) --b;
        while (e < l.size() && std::isdigit(uint8_t(l[e]))) ++e;
        l.replace(b, e - b, "7.5");
        break;
      }
      break;
    }
    case 6: {  // a struct member or declaration dropped
      for (size_t k = 0; k < lines.size(); ++k) {
        const size_t j = (i + k) % lines.size();
        if (lines[j].find(';') != std::string::npos &&
            lines[j].find("vec4 ") != std::string::npos) {
          lines.erase(lines.begin() + long(j));
          break;
        }
      }
      break;
    }
    default:
      lines[i] += " +";
  }
  return joined(lines);
}

TEST_F(Fuzz, ShaderEditsReloadOrFailNamingFileLineAndUndoingThemGivesTheColdImage) {
  const uint64_t seed = env_number("PENUMBRA_FUZZ_SEED", 1);
  const auto budget = std::chrono::seconds(env_number("PENUMBRA_FUZZ_SECONDS", 45));
  std::mt19937_64 rng(seed * 7919 + 1);
  Watchdog watchdog(std::chrono::seconds(180));
  TempTree tree(true);
  scene::Scene s = scene::load_scene(scene::find_scene("default"));
  s.shadows.resolution = 512;
  render::RendererOptions o;
  o.width = 96;
  o.height = 54;
  o.shader_dir = tree.shaders();
  render::Renderer r(ctx(), s, o);
  r.render(0);
  const std::vector<uint8_t> cold = r.read_rgba8();
  std::vector<fs::path> files = r.shader_files();
  std::sort(files.begin(), files.end());
  std::map<fs::path, std::string> originals;
  for (const auto& f : files) originals[f] = testing::read_text(f);

  const auto end = Clock::now() + budget;
  int cases = 0, rebuilt = 0, failed = 0;
  while (Clock::now() < end) {
    const fs::path file = files[size_t(rng() % files.size())];
    const std::string edited = mutate_shader(originals[file], rng);
    const std::string what =
        "seed " + std::to_string(seed) + ", edit " + std::to_string(cases) + " of " + file.string();
    ++cases;
    watchdog.start(what);
    testing::write_text(file, edited);
    const auto result = r.reload({file});
    for (const auto& e : result.errors)
      EXPECT_TRUE(names_a_place(e)) << "a reload error that names no file:line: " << e << "\n"
                                    << what;
    rebuilt += result.rebuilt.empty() ? 0 : 1;
    failed += result.failed.empty() ? 0 : 1;
    r.render(0);
    // Undone: every pipeline reloads, and the image is the cold start's.
    testing::write_text(file, originals[file]);
    const auto undo = r.reload({file});
    EXPECT_TRUE(undo.ok()) << what << ": undoing the edit did not reload: "
                           << ::testing::PrintToString(undo.errors);
    r.render(0);
    EXPECT_EQ(r.read_rgba8(), cold)
        << what << ": the image after undoing differs from a cold start";
    watchdog.done();
    const auto messages = ctx().validation_sink().take();
    for (const auto& m : messages) ADD_FAILURE() << gpu::to_string(m) << "\n" << what;
    if (::testing::Test::HasFailure()) break;
  }
  std::printf(
      "[fuzz] shader edits: seed %llu, %d edits in %lld s: %d rebuilt something, %d "
      "refused\n",
      static_cast<unsigned long long>(seed), cases, static_cast<long long>(budget.count()), rebuilt,
      failed);
  EXPECT_GT(cases, 5);
  EXPECT_GT(failed, 0);
}

}  // namespace
}  // namespace penumbra
