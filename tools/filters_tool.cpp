// penumbra-filters: the shadow filters' table (src/scene/filters.cpp) for the shaders, the docs
// and the Python tools. --glsl prints shaders/penumbra/filters.glsl, --write-glsl FILE writes it
// (atomically), --check-glsl FILE fails when FILE differs from it; --markdown prints the table
// of docs/scenes.md, --check-docs FILE fails when FILE does not hold it; --json prints every row.

#include <cstdio>
#include <fstream>
#include <iostream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/core/json.hpp>
#include <penumbra/scene/filters.hpp>
#include <sstream>

#include "cli.hpp"

namespace {

using namespace penumbra;

std::string json_text(std::string_view s) {
  return json::string(s);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": " + file_problem(path));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string table_json() {
  const scene::ShadowSettings defaults;
  std::ostringstream o;
  o << "[\n";
  const auto table = scene::filter_table();
  for (std::size_t i = 0; i < table.size(); ++i) {
    const scene::FilterSpec& f = table[i];
    o << "  {\"name\": " << json_text(f.name) << ", \"index\": " << i
      << ", \"constant\": " << json_text(f.constant) << ", \"sun\": "
      << (scene::filter_accepts(f.filter, scene::LightKind::sun) ? "true" : "false")
      << ", \"spot\": "
      << (scene::filter_accepts(f.filter, scene::LightKind::spot) ? "true" : "false")
      << ", \"point\": "
      << (scene::filter_accepts(f.filter, scene::LightKind::point) ? "true" : "false")
      << ", \"moments\": " << (f.moments ? "true" : "false") << ", \"fallback\": "
      << (f.fallback ? json_text(scene::filter_spec(*f.fallback).name) : "null") << ", \"keys\": [";
    for (std::size_t k = 0; k < f.keys.size(); ++k)
      o << (k ? ", " : "") << json_text("shadows." + std::string(f.keys[k]));
    o << "], \"default_fetches_per_pixel\": " << f.fetches_per_pixel(defaults, false)
      << ", \"default_reach_texels\": " << f.reach_texels(defaults)
      << ", \"doc\": " << json_text(f.doc) << "}" << (i + 1 < table.size() ? "," : "") << "\n";
  }
  o << "]\n";
  return o.str();
}

}  // namespace

int main(int argc, char** argv) {
  try {
    bool glsl = false, json = false, markdown = false;
    std::string write, check, docs;
    cli::Command cmd("penumbra-filters",
                     "The shadow filters' table: the GLSL constants the shaders include, or JSON.");
    cmd.flag("--glsl", glsl, "print shaders/penumbra/filters.glsl as the table gives it")
        .option(
            "--write-glsl", [&](const std::string& v) { write = v; },
            "write it to FILE (atomically)", "FILE")
        .option(
            "--check-glsl", [&](const std::string& v) { check = v; },
            "exit 1 when FILE is not what the table gives", "FILE")
        .flag("--json", json, "print every filter's row as JSON")
        .flag("--markdown", markdown, "print the filters' table of docs/scenes.md")
        .option(
            "--check-docs", [&](const std::string& v) { docs = v; },
            "exit 1 when FILE does not hold the filters' table as the table gives it", "FILE");
    cmd.parse(argc, argv);
    const std::string text = scene::filters_glsl();
    if (glsl) std::fputs(text.c_str(), stdout);
    if (json) std::fputs(table_json().c_str(), stdout);
    if (markdown) std::fputs(scene::filters_markdown().c_str(), stdout);
    int status = 0;
    if (!docs.empty()) {
      if (read_file(docs).find(scene::filters_markdown()) == std::string::npos) {
        std::fprintf(stderr,
                     "%s does not hold the filters' table as the filter table gives it; "
                     "replace it with the output of penumbra-filters --markdown\n",
                     docs.c_str());
        status = 1;
      } else {
        std::printf("%s holds the filters' table\n", docs.c_str());
      }
    }
    if (!write.empty()) write_file_atomic(write, text);
    if (!check.empty()) {
      const std::string have = read_file(check);
      if (have != text) {
        std::fprintf(stderr,
                     "%s is not what the filter table gives; regenerate it with "
                     "penumbra-filters --write-glsl %s\n",
                     check.c_str(), check.c_str());
        return 1;
      }
      std::printf("%s matches the filter table\n", check.c_str());
    }
    if (!glsl && !json && !markdown && write.empty() && check.empty() && docs.empty())
      throw Error(
          "nothing to do: give --glsl, --write-glsl FILE, --check-glsl FILE, --json, --markdown "
          "or --check-docs FILE");
    return status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-filters: %s\n", e.what());
    return 2;
  }
}
