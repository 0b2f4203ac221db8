#include "cli.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <penumbra/core/error.hpp>
#include <stdexcept>

namespace penumbra::cli {

namespace {

// Text wrapped at `width` columns (CLI11 indents the lines after a newline under the first).
std::string wrapped(const std::string& text, size_t width) {
  std::string out, line;
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find(' ', at);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(at, end - at);
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      out += line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
    at = end + 1;
  }
  return out + line;
}

// Every option's help of app and its subcommands, wrapped to fit 100 columns.
void wrap_help(CLI::App& app) {
  for (CLI::Option* opt : app.get_options())
    if (opt->get_description().find('\n') == std::string::npos)
      opt->description(wrapped(opt->get_description(), 68));
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    sub->description(wrapped(sub->get_description(), 68));
    wrap_help(*sub);
  }
}

}  // namespace

Command::Command(const std::string& name, const std::string& what)
    : root_(std::make_unique<CLI::App>(what, name)), app_(root_.get()) {
  app_->get_formatter()->column_width(30);
  app_->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

Command::Command(CLI::App* app) : app_(app) {}

Command::~Command() = default;

Command& Command::flag(const std::string& name, bool& target, const std::string& help) {
  app_->add_flag(name, target, help);
  return *this;
}

Command& Command::footer(const std::string& text) {
  app_->footer(text);
  return *this;
}

Command& Command::subcommand(const std::string& name, const std::string& what) {
  app_->require_subcommand(1, 1);
  subcommands_.push_back(std::unique_ptr<Command>(new Command(app_->add_subcommand(name, what))));
  return *subcommands_.back();
}

bool Command::parsed() const {
  return app_->parsed();
}

void Command::parse(int argc, char** argv) {
  wrap_help(*app_);
  try {
    app_->parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::fputs(app_->help().c_str(), stdout);
    std::exit(0);
  } catch (const CLI::ParseError& e) {
    throw Error(std::string(e.what()) + " (try --help)");
  }
}

namespace {

// What the help calls the value of the tools' common flags.
std::string value_name(const std::string& flag) {
  static const std::map<std::string, std::string> names{{"--scene", "NAME|FILE"},
                                                        {"--size", "WxH"},
                                                        {"--out", "PATH"},
                                                        {"--shader-dir", "DIR"},
                                                        {"--cache", "DIR"},
                                                        {"--report", "DIR"},
                                                        {"--review", "DIR"},
                                                        {"--script", "FILE|-"},
                                                        {"--command", "LINE"},
                                                        {"--set", "KEY=VALUE"},
                                                        {"--view", "VIEW"},
                                                        {"--filter", "FILTER"},
                                                        {"--light", "NAME"},
                                                        {"--threshold", "T"},
                                                        {"--seed", "S"},
                                                        {"--case,--scene", "NAME"},
                                                        {"--against", "CLASS"},
                                                        {"--file", "FILE"},
                                                        {"--modes", "M,..."},
                                                        {"--flicker", "PATH,...|all"},
                                                        {"--truth-flicker", "PATH"},
                                                        {"--terminator", "smooth|geometric"}};
  const auto it = names.find(flag);
  return it != names.end() ? it->second : "N";
}

}  // namespace

Command& Command::option(const std::string& flag, std::function<void(const std::string&)> take,
                         const std::string& help, const std::string& type) {
  app_->add_option_function<std::string>(flag, std::move(take), help)
      ->type_name(type.empty() ? value_name(flag) : type)
      ->trigger_on_parse()
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  return *this;
}

std::uint64_t whole64(const std::string& flag, const std::string& v, std::uint64_t lo,
                      std::uint64_t hi) {
  unsigned long long x = 0;
  try {
    size_t used = 0;
    if (v.empty() || v[0] == '-' || v[0] == '+') throw std::invalid_argument(v);
    x = std::stoull(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
  } catch (const std::exception&) {
    throw Error(flag + " " + v + ": expected a whole number in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  if (x < lo || x > hi) {
    throw Error(flag + " " + v + ": out of range; must be in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  return x;
}

std::uint32_t whole(const std::string& flag, const std::string& v, std::uint32_t lo,
                    std::uint32_t hi) {
  return static_cast<std::uint32_t>(whole64(flag, v, lo, hi));
}

std::pair<std::uint32_t, std::uint32_t> size(const std::string& flag, const std::string& v,
                                             std::uint32_t lo, std::uint32_t hi) {
  const auto x = v.find('x');
  if (x == std::string::npos) throw Error(flag + " " + v + ": expected WxH, e.g. 1280x720");
  return {whole(flag + " " + v + ": width", v.substr(0, x), lo, hi),
          whole(flag + " " + v + ": height", v.substr(x + 1), lo, hi)};
}

double number(const std::string& flag, const std::string& v, double lo, double hi) {
  double x = 0.0;
  try {
    size_t used = 0;
    x = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
  } catch (const std::exception&) {
    throw Error(flag + " " + v + ": expected a number in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  if (!std::isfinite(x) || x < lo || x > hi) {
    throw Error(flag + " " + v + ": out of range; must be in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  return x;
}

std::array<double, 3> triple(const std::string& flag, const std::string& v) {
  std::array<double, 3> out{};
  std::size_t at = 0, n = 0;
  for (; n < 3 && at <= v.size(); ++n) {
    const std::size_t comma = std::min(v.find(',', at), v.size());
    const std::string part = v.substr(at, comma - at);
    try {
      std::size_t used = 0;
      out[n] = std::stod(part, &used);
      if (used != part.size() || !std::isfinite(out[n])) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw Error(flag + " " + v + ": '" + part + "' is not a finite number (expected X,Y,Z)");
    }
    at = comma + 1;
  }
  if (n != 3 || at <= v.size())
    throw Error(flag + " " + v + ": expected three numbers X,Y,Z");
  return out;
}

std::string one_of(const std::string& flag, const std::string& v,
                   const std::vector<std::string>& choices) {
  if (std::find(choices.begin(), choices.end(), v) != choices.end()) return v;
  std::string all;
  for (const auto& c : choices) all += (all.empty() ? "" : ", ") + c;
  throw Error(flag + " " + v + ": expected one of " + all);
}

}  // namespace penumbra::cli
