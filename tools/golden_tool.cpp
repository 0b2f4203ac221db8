// penumbra-golden: the reviewed golden images of tests/golden (list, check, update). Goldens are
// written only by `update`, only for frames within their case's accuracy budget against the
// ray-traced reference, and only after the before / after / difference review page is written.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/golden/golden.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/validation.hpp>
#include <string>
#include <vector>

#include "cli.hpp"

namespace {
namespace fs = std::filesystem;
namespace golden = penumbra::golden;
using penumbra::Error;

struct Options {
  std::string command;
  std::vector<std::string> cases;
  bool all = false, dry_run = false, cache = true, stats = false;
  std::string against;
  fs::path report = "out/golden-check", review = "out/golden-review", shader_dir, cache_dir;
  uint32_t samples = 256;
};

Options parse(int argc, char** argv) {
  Options o;
  penumbra::cli::Command app("penumbra-golden",
                             "The reviewed goldens of tests/golden: list, check and update them.");
  app.footer("$PENUMBRA_GOLDEN_DIR replaces tests/golden.");
  penumbra::cli::Command& list = app.subcommand(
      "list", "the cases (tests/golden/cases.toml) and the device classes with goldens");
  penumbra::cli::Command& check = app.subcommand(
      "check",
      "render each case on this device and compare it with its golden, region by region; a "
      "report (expected, actual, difference, regions, index.html) per case into --report; exit "
      "1 when one fails");
  penumbra::cli::Command& update = app.subcommand(
      "update",
      "render each case, measure it against the ray-traced reference, refuse it when it is over "
      "its accuracy budget, write the review page (current golden, new frame, difference) into "
      "--review, then replace tests/golden/<device class>/<case>/ (not with --dry-run)");
  for (penumbra::cli::Command* c : {&check, &update}) {
    c->option(
        "--case,--scene", [&](const std::string& v) { o.cases.push_back(v); },
        "a case name; repeatable (check: default every case)");
    c->option(
        "--shader-dir", [&](const std::string& v) { o.shader_dir = v; },
        "render with the shaders of this tree instead of the source tree's");
  }
  check.option(
      "--report", [&](const std::string& v) { o.report = v; },
      "where the reports go (default out/golden-check)");
  check.option(
      "--against", [&](const std::string& v) { o.against = v; },
      "compare with another device class's goldens (calibration: how far lavapipe and a GPU "
      "differ)");
  check.flag("--stats", o.stats,
             "per region, the pixels differing by more than 1/255, 0.02, 0.1, 0.25 and 0.5, "
             "as CSV lines on stdout");
  update.flag("--all", o.all, "every case");
  update.flag("--dry-run", o.dry_run, "measure and write the review page, replace nothing");
  update.option(
      "--review", [&](const std::string& v) { o.review = v; },
      "where the review page goes (default out/golden-review)");
  update.option(
      "--samples",
      [&](const std::string& v) { o.samples = penumbra::cli::whole("--samples", v, 1, 1u << 20); },
      "reference rays per receiver in penumbrae, as penumbra-reference takes it (default 256)");
  update.option(
      "--cache", [&](const std::string& v) { o.cache_dir = v; },
      "the reference cache, as penumbra-reference takes it");
  bool no_cache = false;
  update.flag("--no-cache", no_cache, "trace every time");
  app.parse(argc, argv);
  if (no_cache) o.cache = false;
  o.command = list.parsed() ? "list" : check.parsed() ? "check" : "update";
  if (o.command == "update" && o.cases.empty() && !o.all)
    throw Error("update: name the cases (--case NAME) or pass --all; it never runs implicitly");
  return o;
}

std::vector<golden::Case> select(const std::vector<golden::Case>& all, const Options& o,
                                 const fs::path& cases_file) {
  if (o.cases.empty()) return all;
  std::vector<golden::Case> out;
  for (const auto& name : o.cases) {
    const auto it =
        std::find_if(all.begin(), all.end(), [&](const golden::Case& c) { return c.name == name; });
    if (it == all.end()) {
      std::string names;
      for (const auto& c : all) names += (names.empty() ? "" : ", ") + c.name;
      throw Error("no case '" + name + "' in " + cases_file.string() + " (cases: " + names + ")");
    }
    out.push_back(*it);
  }
  return out;
}

int list(const std::vector<golden::Case>& cases, const fs::path& root) {
  std::vector<std::string> classes;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory()) classes.push_back(e.path().filename().string());
  std::sort(classes.begin(), classes.end());
  for (const auto& c : cases) {
    std::printf("%-22s %-28s %4ux%-4u", c.name.c_str(), c.scene.c_str(), c.width, c.height);
    for (const auto& cls : classes)
      if (fs::exists(root / cls / c.name / "golden.toml")) std::printf(" %s", cls.c_str());
    std::printf("\n");
    if (!c.description.empty()) std::printf("    %s\n", c.description.c_str());
  }
  return 0;
}

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const fs::path root = golden::golden_root();
  const fs::path cases_file = root / "cases.toml";
  const auto all = golden::load_cases(cases_file);
  const auto cases = select(all, o, cases_file);
  if (o.command == "list") return list(all, root);

  penumbra::gpu::Context ctx;
  const std::string cls = golden::device_class(ctx.info());
  std::printf("device: %s (%s %s), device class %s\n", ctx.info().name.c_str(),
              ctx.info().driver_name.c_str(), ctx.info().driver_info.c_str(), cls.c_str());
  int failed = 0;
  std::string index;  // check: one line per case on the report's index.html
  if (o.stats)
    std::printf(
        "stats,case,image,region,pixels,over_1/255,over_0.02,over_0.1,over_0.25,over_0.5,"
        "worst\n");
  for (const auto& c : cases) {
    const std::string golden_class = o.command == "check" && !o.against.empty() ? o.against : cls;
    const fs::path dir = root / golden_class / c.name;
    const auto old = golden::load_golden(dir);
    if (o.command == "check") {
      if (!old) {
        std::printf("%s: no golden for %s (penumbra-golden update --case %s)\n", c.name.c_str(),
                    golden_class.c_str(), c.name.c_str());
        ++failed;
        continue;
      }
      const golden::Frame frame = golden::render_case(ctx, c, o.shader_dir);
      const golden::Comparison cmp = golden::compare(old->frame, frame);
      const fs::path page =
          golden::write_report(o.report / c.name,
                               {c.name + " (" + cls + " against " + golden_class + ")",
                                "golden by " + old->device, "golden", "actual"},
                               old->frame, frame, cmp);
      std::printf("%s: %s\n%s  report: %s\n", c.name.c_str(), cmp.passed() ? "passed" : "FAILED",
                  cmp.summary().c_str(), page.string().c_str());
      failed += !cmp.passed();
      index += "<li><a href=\"" + c.name + "/index.html\">" + c.name +
               "</a>: " + (cmp.passed() ? "passed" : "<b style=\"color:#b00\">FAILED</b>") +
               "</li>\n";
      if (o.stats)
        for (const auto& r : cmp.results)
          std::printf("stats,%s,%s,%s,%llu,%llu,%llu,%llu,%llu,%llu,%.4f\n", c.name.c_str(),
                      r.image.c_str(), r.region.c_str(), (unsigned long long)r.pixels,
                      (unsigned long long)r.histogram[0], (unsigned long long)r.histogram[1],
                      (unsigned long long)r.histogram[2], (unsigned long long)r.histogram[3],
                      (unsigned long long)r.histogram[4], double(r.worst));
      continue;
    }
    // update
    penumbra::reference::MeasureOptions mo;
    mo.trace.samples = o.samples;
    mo.trace.progress = true;
    if (o.cache)
      mo.cache_dir = o.cache_dir.empty() ? penumbra::reference::default_cache_dir() : o.cache_dir;
    const golden::CaseMeasurement m = golden::measure_case(ctx, c, mo);
    for (const auto& l : m.measurement.lights)
      std::printf("%s %s\n", c.name.c_str(), l.metrics.to_line().c_str());
    std::optional<golden::Comparison> cmp;
    if (old) cmp = golden::compare(old->frame, m.frame);
    const fs::path page = golden::write_report(
        o.review / c.name,
        {"update " + c.name + " (" + cls + ")",
         old ? "current golden by " + old->device + " against the new frame on " + ctx.info().name
             : "no golden yet for " + cls + ": the new frame on " + ctx.info().name,
         "current golden", "new frame"},
        old ? std::optional<golden::Frame>(old->frame) : std::nullopt, m.frame, cmp);
    if (cmp) std::printf("changes against the current golden:\n%s", cmp->summary().c_str());
    std::printf("  review: %s\n", page.string().c_str());
    if (!m.over_budget.empty()) {
      std::printf("%s: NOT ACCEPTED, over its accuracy budget against the reference:\n",
                  c.name.c_str());
      for (const auto& v : m.over_budget) std::printf("  %s\n", v.c_str());
      ++failed;
      continue;
    }
    if (o.dry_run) {
      std::printf("%s: within budget; --dry-run: %s left as it was\n", c.name.c_str(),
                  dir.string().c_str());
      continue;
    }
    golden::Golden g;
    g.case_name = c.name;
    g.device_class = cls;
    g.device = ctx.info().name;
    g.driver = ctx.info().driver_name + " " + ctx.info().driver_info;
    g.frame = m.frame;
    golden::write_golden(dir, g);
    std::printf("%s: wrote %s\n", c.name.c_str(), dir.string().c_str());
  }
  if (o.command == "check" && !index.empty()) {
    const fs::path page = o.report / "index.html";
    penumbra::write_file_atomic(
        page,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>golden "
        "check</title></head><body style=\"font:14px system-ui,sans-serif\"><h1>golden "
        "check (" +
            cls + ")</h1><ul>\n" + index + "</ul></body></html>\n");
    std::printf("report: %s\n", page.string().c_str());
  }
  if (ctx.validation_enabled() && ctx.validation_sink().total_seen() != 0) {
    std::fprintf(stderr, "validation: %zu messages\n", ctx.validation_sink().total_seen());
    return 1;
  }
  return failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-golden: %s\n", e.what());
    return 1;
  }
}
