#include "script.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <sstream>

namespace penumbra::runtime {
namespace fs = std::filesystem;

namespace {

const char* const kCommands =
    "scene, size, set, get, view, frame, render, screenshot, timings, reload, wait_reload, edit, "
    "replace, expect_reload_ok, expect_reload_error, expect_rebuilt, echo, quit";

uint32_t whole(const std::string& cmd, const std::string& v, uint32_t lo, uint32_t hi) {
  char* end = nullptr;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || end != v.c_str() + v.size() || x < long(lo) || x > long(hi))
    throw Error(cmd + " " + v + ": expected a whole number in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  return static_cast<uint32_t>(x);
}

void arity(const std::vector<std::string>& a, size_t lo, size_t hi, const char* usage) {
  if (a.size() - 1 < lo || a.size() - 1 > hi)
    throw Error(a[0] + ": expected " + usage + " (got " + std::to_string(a.size() - 1) +
                " argument(s))");
}

std::string rest(const std::vector<std::string>& a, size_t from) {
  std::string s;
  for (size_t i = from; i < a.size(); ++i) s += (i > from ? " " : "") + a[i];
  return s;
}

std::string list(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "(none)" : s;
}

// Writes text next to `file` and renames it over the original, as editors' atomic saves do.
void atomic_write(const fs::path& file, const std::string& text) {
  const fs::path tmp = file.parent_path() / ("." + file.filename().string() + ".penumbra-save");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out) throw Error(tmp.string() + ": cannot write");
  }
  std::error_code ec;
  fs::rename(tmp, file, ec);
  if (ec) throw Error(file.string() + ": cannot rename the saved file over it: " + ec.message());
}

}  // namespace

std::vector<std::string> split_command(const std::string& line) {
  // A NUL byte would cut every path and message at it: the line is refused, shown whole.
  if (const size_t nul = line.find('\0'); nul != std::string::npos) {
    throw Error("'" + printable(line) + "' holds a NUL byte (column " + std::to_string(nul + 1) +
                ")");
  }
  std::vector<std::string> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= line.size() || line[i] == '#') break;
    std::string tok;
    bool quoted = false;
    while (i < line.size()) {
      const char c = line[i];
      if (quoted) {
        if (c == '"') {
          quoted = false;
        } else if (c == '\\' && i + 1 < line.size()) {
          const char n = line[++i];
          tok += n == 'n' ? '\n' : n == 't' ? '\t' : n;
        } else {
          tok += c;
        }
      } else if (c == '"') {
        quoted = true;
      } else if (c == ' ' || c == '\t' || c == '\r') {
        break;
      } else {
        tok += c;
      }
      ++i;
    }
    if (quoted) throw Error("unterminated \" quote");
    out.push_back(tok);
  }
  return out;
}

Script::Script(gpu::Context& ctx, ScriptSetup setup) : ctx_(ctx), setup_(std::move(setup)) {}
Script::~Script() = default;

Session& Script::session() {
  if (!session_) {
    const fs::path file = scene::find_scene(setup_.scene);
    session_ = std::make_unique<Session>(ctx_, scene::load_scene(file), setup_.session);
    for (const auto& [key, value] : setup_.initial_settings) session_->set(key, value);
  }
  return *session_;
}

bool Script::run(std::istream& in, const std::string& name) {
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!run_line(line, name + ":" + std::to_string(n))) return false;
  }
  return true;
}

bool Script::run_line(const std::string& line, const std::string& where) {
  std::vector<std::string> args;
  try {
    args = split_command(line);
  } catch (const std::exception& e) {
    throw Error(where + ": " + e.what());
  }
  if (args.empty()) return true;
  try {
    return execute(args);
  } catch (const std::exception& e) {
    // "t.txt:3: set shadows.cascades 9: expected ..." (the command is named once).
    const std::string what = e.what();
    auto starts = [&](const std::string& p) { return what.rfind(p, 0) == 0; };
    std::string msg;
    if (starts(args[0] + " ") || starts(args[0] + ":") || starts("unknown command"))
      msg = what;
    else if (args.size() > 1 && starts(args[1] + " "))
      msg = args[0] + " " + what;
    else
      msg = args[0] + ": " + what;
    throw Error(where + ": " + msg);
  }
}

fs::path Script::shader_file(const std::string& arg) {
  const fs::path p(arg);
  const fs::path dir = has_session()                       ? session_->shader_dir()
                       : setup_.session.shader_dir.empty() ? render::default_shader_dir()
                                                           : setup_.session.shader_dir;
  return p.is_absolute() ? p : dir / p;
}

bool Script::execute(const std::vector<std::string>& a) {
  const std::string& cmd = a[0];
  auto timeout = [&](size_t index) {
    return a.size() > index ? std::chrono::milliseconds(whole(cmd, a[index], 1, 3600000))
                            : setup_.timeout;
  };
  if (cmd == "quit") {
    arity(a, 0, 0, "no arguments");
    return false;
  }
  if (cmd == "echo") {
    std::printf("%s\n", rest(a, 1).c_str());
    std::fflush(stdout);
  } else if (cmd == "scene") {
    arity(a, 1, 1, "a scene name or .toml path");
    const fs::path file = scene::find_scene(a[1]);
    if (!session_) {
      scene::load_scene(file);  // errors now, at this line
      setup_.scene = a[1];
    } else {
      session_->load_scene(scene::load_scene(file));
    }
  } else if (cmd == "size") {
    arity(a, 1, 1, "WxH, e.g. 320x180");
    const auto x = a[1].find('x');
    if (x == std::string::npos) throw Error("size " + a[1] + ": expected WxH, e.g. 320x180");
    const uint32_t w = whole(cmd, a[1].substr(0, x), 1, 16384);
    const uint32_t h = whole(cmd, a[1].substr(x + 1), 1, 16384);
    if (!session_) {
      setup_.session.width = w;
      setup_.session.height = h;
    } else {
      session_->resize(w, h);
    }
  } else if (cmd == "set") {
    if (a.size() < 3) throw Error("set: expected KEY VALUE");
    session().set(a[1], rest(a, 2));
  } else if (cmd == "get") {
    arity(a, 1, 1, "KEY");
    std::printf("%s = %s\n", a[1].c_str(), session().get(a[1]).c_str());
    std::fflush(stdout);
  } else if (cmd == "view") {
    arity(a, 1, 1, "a view name");
    session().set("render.view", a[1]);
  } else if (cmd == "frame") {
    arity(a, 1, 1, "a frame index");
    session().set_frame_index(whole(cmd, a[1], 0, 1u << 30));
  } else if (cmd == "render") {
    arity(a, 0, 1, "[N]");
    session().render(a.size() > 1 ? whole(cmd, a[1], 1, 100000) : 1);
  } else if (cmd == "screenshot") {
    arity(a, 1, 1, "PATH.png");
    if (fs::path(a[1]).extension() != ".png")
      throw Error("screenshot " + a[1] + ": expected a .png path");
    session().screenshot(a[1]);
    session().log("[script] wrote " + a[1]);
  } else if (cmd == "timings") {
    arity(a, 0, 0, "no arguments");
    if (!session().rendered()) session().render(1);
    session().log(session().timings_text());
  } else if (cmd == "reload") {
    if (a.size() < 2) throw Error("reload: expected FILE...");
    std::vector<fs::path> files;
    for (size_t i = 1; i < a.size(); ++i) {
      files.push_back(shader_file(a[i]));
      // A file reloads only where a pipeline reads it (a deleted include too: it keeps the last
      // good pipelines until it is back); a file no pipeline reads names nothing to reload, and
      // the message says what the path is (a typo, a file of another tree, a device).
      if (session().renderer().pipelines_reading(files.back()).empty()) {
        const std::string problem = file_problem(files.back());
        throw Error("reload " + a[i] + ": " + files.back().string() + " " +
                    (problem == "not found"
                         ? std::string("does not exist, and no pipeline reads it")
                     : problem.empty() ? std::string("is read by no pipeline: nothing to reload")
                                       : problem + ", and no pipeline reads it"));
      }
    }
    session().reload(files);
  } else if (cmd == "wait_reload") {
    arity(a, 0, 1, "[TIMEOUT_MS]");
    const auto t = timeout(1);
    if (!session().wait_reload(t))
      throw Error("wait_reload: no edit of a shader file in " + std::to_string(t.count()) + " ms");
  } else if (cmd == "edit") {
    arity(a, 1, 2, "FILE [TIMEOUT_MS]");
    const fs::path f = shader_file(a[1]);
    Session& s = session();
    s.log("[script] waiting for an edit of " + f.string());
    const auto t = timeout(2);
    if (!s.wait_reload(t, f))
      throw Error("edit " + a[1] + ": no edit of " + f.string() + " in " +
                  std::to_string(t.count()) + " ms");
  } else if (cmd == "replace") {
    arity(a, 3, 4, "FILE OLD NEW [TIMEOUT_MS]");
    Session& s = session();
    std::error_code ec;
    if (fs::weakly_canonical(s.shader_dir(), ec) ==
        fs::weakly_canonical(render::default_shader_dir(), ec))
      throw Error(
          "replace: refusing to edit the repository's shaders/; run on a copy "
          "(--shader-dir DIR)");
    const fs::path f = shader_file(a[1]);
    std::ifstream in(f, std::ios::binary);
    if (const std::string problem = file_problem(f); !problem.empty())
      throw Error("replace: " + f.string() + " " + problem);
    if (!in) throw Error("replace: " + f.string() + ": cannot read");
    std::stringstream buf;
    buf << in.rdbuf();
    std::string text = buf.str();
    const auto at = text.find(a[2]);
    if (at == std::string::npos)
      throw Error("replace: \"" + a[2] + "\" does not occur in " + f.string());
    text.replace(at, a[2].size(), a[3]);
    atomic_write(f, text);
    const auto t = timeout(4);
    if (!s.wait_reload(t, f))
      throw Error("replace " + a[1] + ": the edit was not reloaded in " +
                  std::to_string(t.count()) + " ms");
  } else if (cmd == "expect_reload_ok") {
    arity(a, 0, 0, "no arguments");
    const Session& s = session();
    if (!s.last_reload()) throw Error("expect_reload_ok: no reload happened");
    if (!s.errors().empty())
      throw Error("expect_reload_ok: a pipeline failed to reload: " + s.error_text());
  } else if (cmd == "expect_reload_error") {
    if (a.size() < 2) throw Error("expect_reload_error: expected TEXT");
    const Session& s = session();
    const std::string want = rest(a, 1);
    if (s.errors().empty())
      throw Error("expect_reload_error: no pipeline is in error (expected an error with '" + want +
                  "')");
    if (s.error_text().find(want) == std::string::npos)
      throw Error("expect_reload_error: the error does not contain '" + want +
                  "': " + s.error_text());
  } else if (cmd == "expect_rebuilt") {
    const Session& s = session();
    if (!s.last_reload()) throw Error("expect_rebuilt: no reload happened");
    const auto& got = s.last_reload()->result.rebuilt;
    std::vector<std::string> want(a.begin() + 1, a.end());
    auto first_word = [](const std::string& n) { return n.substr(0, n.find(' ')); };
    std::vector<std::string> left = got;
    bool ok = true;
    for (const auto& w : want) {
      const auto it = std::find_if(left.begin(), left.end(), [&](const std::string& n) {
        return n == w || first_word(n) == w;
      });
      if (it == left.end()) {
        ok = false;
        break;
      }
      left.erase(it);
    }
    if (!ok || !left.empty())
      throw Error("expect_rebuilt: expected " + list(want) + ", the last reload rebuilt " +
                  list(got));
  } else {
    throw Error("unknown command '" + cmd + "' (expected one of " + kCommands + ")");
  }
  return true;
}

}  // namespace penumbra::runtime
