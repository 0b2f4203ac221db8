#include "glsl_scan.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <penumbra/core/text.hpp>
#include <set>
#include <sstream>

namespace penumbra::testing::detail {
namespace {

namespace fs = std::filesystem;

bool ident_start(char c) {
  return std::isalpha(static_cast<unsigned char>(c)) || c == '_';
}
bool ident_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

// The text with comments and preprocessor lines blanked (newlines kept, so offsets map to the
// same lines), and the #include targets it names.
std::string blank_comments(const std::string& in, std::vector<std::string>& includes) {
  std::string out = in;
  size_t i = 0;
  bool line_start = true;
  while (i < out.size()) {
    const char c = out[i];
    if (c == '/' && i + 1 < out.size() && out[i + 1] == '/') {
      while (i < out.size() && out[i] != '\n') out[i++] = ' ';
    } else if (c == '/' && i + 1 < out.size() && out[i + 1] == '*') {
      while (i < out.size() && !(out[i] == '*' && i + 1 < out.size() && out[i + 1] == '/')) {
        if (out[i] != '\n') out[i] = ' ';
        ++i;
      }
      for (int k = 0; k < 2 && i < out.size(); ++k) out[i++] = ' ';
    } else if (c == '#' && line_start) {
      const size_t end = out.find('\n', i);
      const std::string directive = out.substr(i, end == std::string::npos ? end : end - i);
      if (directive.find("include") != std::string::npos) {
        const size_t open = directive.find_first_of("\"<");
        const size_t close =
            open == std::string::npos ? open : directive.find_first_of("\">", open + 1);
        if (close != std::string::npos)
          includes.push_back(directive.substr(open + 1, close - open - 1));
      }
      while (i < out.size() && out[i] != '\n') out[i++] = ' ';
    } else {
      if (c == '\n')
        line_start = true;
      else if (!std::isspace(static_cast<unsigned char>(c)))
        line_start = false;
      ++i;
    }
  }
  return out;
}

std::string collapse(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (!out.empty() && out.back() != ' ') out += ' ';
    } else {
      out += c;
    }
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

const std::set<std::string>& not_types() {
  static const std::set<std::string> words{"return",  "if",     "else", "while",  "for",
                                           "do",      "switch", "case", "layout", "struct",
                                           "uniform", "buffer", "in",   "out",    "inout"};
  return words;
}

void scan(const fs::path& file, const std::vector<fs::path>& dirs, std::set<fs::path>& seen,
          std::vector<GlslFunction>& out) {
  std::error_code ec;
  const fs::path canonical = fs::weakly_canonical(file, ec);
  if (!seen.insert(ec ? file : canonical).second) return;
  if (!fs::is_regular_file(file, ec)) return;
  std::ifstream in(file, std::ios::binary);
  std::stringstream buf;
  buf << in.rdbuf();
  std::vector<std::string> includes;
  const std::string text = blank_comments(buf.str(), includes);
  int depth = 0, line = 1;
  size_t statement = 0;  // where the current top-level statement began
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line;
    if (c == '{') ++depth;
    if (c == '}') depth = std::max(0, depth - 1);
    if ((c == '}' || c == ';') && depth == 0) statement = i + 1;
    if (depth != 0 || !ident_start(c) || (i > 0 && ident_char(text[i - 1]))) continue;
    // An identifier at the top level: a function's name when '(' follows and a type
    // (another identifier, or an array's ']') comes before it.
    size_t e = i;
    while (e < text.size() && ident_char(text[e])) ++e;
    size_t p = e;
    while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
    const std::string name = text.substr(i, e - i);
    if (p >= text.size() || text[p] != '(') continue;
    size_t b = i;
    while (b > statement && std::isspace(static_cast<unsigned char>(text[b - 1]))) --b;
    if (b == statement || !(ident_char(text[b - 1]) || text[b - 1] == ']')) continue;
    size_t t = b;
    while (t > statement && ident_char(text[t - 1])) --t;
    if (not_types().count(text.substr(t, b - t)) || not_types().count(name)) continue;
    const size_t close = text.find(')', p);
    if (close == std::string::npos) break;
    size_t after = close + 1;
    while (after < text.size() && std::isspace(static_cast<unsigned char>(text[after]))) ++after;
    if (after >= text.size() || (text[after] != '{' && text[after] != ';')) continue;
    const int decl_line = line;
    out.push_back({file, decl_line, name, collapse(text.substr(statement, close + 1 - statement))});
  }
  for (const std::string& inc : includes) {
    std::vector<fs::path> where{file.parent_path()};
    where.insert(where.end(), dirs.begin(), dirs.end());
    for (const fs::path& d : where) {
      if (fs::is_regular_file(d / inc, ec)) {
        scan(d / inc, dirs, seen, out);
        break;
      }
    }
  }
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

std::vector<GlslFunction> glsl_functions(const fs::path& file,
                                         const std::vector<fs::path>& include_dirs) {
  std::vector<GlslFunction> out;
  std::set<fs::path> seen;
  scan(file, include_dirs, seen, out);
  return out;
}

std::string explain_no_match(const std::vector<GlslFunction>& declared, const std::string& name,
                             const std::string& wanted) {
  std::string same, near;
  for (const GlslFunction& f : declared) {
    const std::string entry =
        "    " + f.file.string() + ":" + std::to_string(f.line) + ": " + f.signature + "\n";
    if (f.name == name) {
      same += entry;
    } else if (penumbra::edit_distance(f.name, name) <= 2 || lower(f.name) == lower(name)) {
      near += entry;
    }
  }
  if (same.empty() && near.empty()) return {};
  std::string out = "  the C++ signature asks for: " + wanted + "\n";
  if (!same.empty()) {
    out += "  the GLSL declares '" + name + "' as:\n" + same;
  } else {
    out += "  no GLSL function is named '" + name + "'\n";
  }
  if (!near.empty()) out += "  near names (did you mean one of these?):\n" + near;
  return out;
}

}  // namespace penumbra::testing::detail
