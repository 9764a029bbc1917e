#pragma once
// The command line of every process and every agvcal sub-command, read by CLI11: each declares
// its positional arguments and options once, and --help (generated from those declarations),
// --version and the exit statuses of docs/spec/cli.md follow from them.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace agvcal_process {

// The help of --lcm-url, the same for every process on the bus.
extern const char* const kLcmUrlHelp;

// The program's version (CMake's project version and git describe at build time): what
// --version prints after the name.
const char* Version();

class CommandLine {
 public:
  // `name` as typed ("agvcal-sim", "agvcal solve"): in the usage line and in error messages.
  explicit CommandLine(std::string name);
  ~CommandLine();
  CommandLine(const CommandLine&) = delete;
  CommandLine& operator=(const CommandLine&) = delete;

  // What the command does: --help prints it under the usage line.
  CommandLine& Description(const std::string& text);
  // Declarations, listed by --help in this order. A positional argument is required; `value`
  // names an option's value in the help ("--out RESULT.json"). A help text may hold newlines.
  CommandLine& Positional(const std::string& name, const std::string& help);
  CommandLine& Option(const std::string& name, const std::string& value, const std::string& help);
  CommandLine& Flag(const std::string& name, const std::string& help);
  // A sub-command, listed by --help (the front end dispatches it before parsing).
  CommandLine& Command(const std::string& name, const std::string& summary);
  // Printed after the options (exit statuses, notes).
  CommandLine& Footer(const std::string& text);

  // Parses argv[first..]. Returns the exit status to end with at once: 0 after --help (the help
  // on stdout) or --version; 2 after a bad command line (one line on stderr naming the option
  // or argument); nothing when the command should go on.
  std::optional<int> Parse(int argc, char** argv, int first);

  std::string Help() const;

  // After Parse: the whole command line as run (argv, quoted for a POSIX shell), the positional
  // arguments in their declared order, and the options given.
  std::string as_run;
  std::vector<std::string> positional;
  bool Has(const std::string& option) const;
  std::string Get(const std::string& option, const std::string& fallback) const;
  // InputError naming the option unless its value is a number.
  double GetDouble(const std::string& option, double fallback) const;

 private:
  int Refuse(const std::string& problem) const;

  std::string name_;
  std::unique_ptr<CLI::App> app_;
  std::vector<std::string> positional_names_;
  std::vector<std::string> commands_;
  std::map<std::string, std::string> values_;  // option or positional name -> value given
  std::map<std::string, CLI::Option*> options_;
};

}  // namespace agvcal_process
