#pragma once
// The command lines of Penumbra's C++ tools (penumbra-view, penumbra-reference, penumbra-golden,
// the benches): CLI11 (Debian's libcli11-dev) reads the flags, their values and --help, and
// reports an unknown flag or a missing value; each value is checked as it is read, so an error
// names the flag and the value ("--frames 0: out of range; must be in [1, 10000]"). CLI11 is
// included by cli.cpp alone (about 14 s of compile per file that includes it).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace CLI {
class App;
}

namespace penumbra::cli {

class Command {
 public:
  // A tool's command line: its name and one line of what it does (the help's first line).
  Command(const std::string& name, const std::string& what);
  ~Command();
  Command(const Command&) = delete;
  Command& operator=(const Command&) = delete;

  // An option taking one value, which may repeat: `take` gets each value as it is parsed, in
  // command-line order (interleaved options keep their order), and may throw penumbra::Error.
  // `type` names the value in the help; empty: the tools' usual name for that flag (N for a
  // count, WxH, DIR, KEY=VALUE, ...). "--a,--b" gives two names.
  Command& option(const std::string& flag, std::function<void(const std::string&)> take,
                  const std::string& help, const std::string& type = {});
  // A flag without a value: sets `target` to true ("!--no-x": to false).
  Command& flag(const std::string& name, bool& target, const std::string& help);
  // Text after the options in --help.
  Command& footer(const std::string& text);
  // A subcommand (penumbra-golden list|check|update): with any, exactly one must be given.
  Command& subcommand(const std::string& name, const std::string& what);
  // For a subcommand, after parse(): whether it was the one given.
  bool parsed() const;

  // Parses argv. --help (-h) prints the help and exits with status 0; an unknown flag, a
  // missing value or a stray argument throws penumbra::Error with CLI11's message and
  // "(try --help)"; the checks of option() throw as they come, in command-line order.
  void parse(int argc, char** argv);

 private:
  explicit Command(CLI::App* app);
  std::unique_ptr<CLI::App> root_;  // the root owns the CLI11 app; subcommands point into it
  CLI::App* app_ = nullptr;
  std::vector<std::unique_ptr<Command>> subcommands_;
};

// A whole number in [lo, hi], or an error naming the flag, the value and the range.
std::uint32_t whole(const std::string& flag, const std::string& v, std::uint32_t lo,
                    std::uint32_t hi);
// The same for 64-bit values (seeds).
std::uint64_t whole64(const std::string& flag, const std::string& v, std::uint64_t lo,
                      std::uint64_t hi);
// WxH, each side a whole number in [lo, hi] ("--size 64x: height : expected a whole number").
std::pair<std::uint32_t, std::uint32_t> size(const std::string& flag, const std::string& v,
                                             std::uint32_t lo, std::uint32_t hi);
// A finite number in [lo, hi].
double number(const std::string& flag, const std::string& v, double lo, double hi);
// Three finite numbers "X,Y,Z" ("--move 1,2: expected three numbers X,Y,Z").
std::array<double, 3> triple(const std::string& flag, const std::string& v);
// One of `choices`: "--mode x: expected one of a, b".
std::string one_of(const std::string& flag, const std::string& v,
                   const std::vector<std::string>& choices);

}  // namespace penumbra::cli
