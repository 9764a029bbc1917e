#include "common/command_line.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <stdexcept>

#include "agvcal_version.h"
#include "calib/core/errors.h"

namespace agvcal_process {

const char* const kLcmUrlHelp = "LCM provider (default: $LCM_DEFAULT_URL or LCM's default)";

const char* Version() { return AGVCAL_VERSION; }

namespace {

// CLI11's layout with the usage line first (as man pages have it), the description under it,
// and an option's value shown by the name it was declared with ("--out RESULT.json").
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter() {
    label("Usage", "usage");
    label("Positionals", "Arguments");
    label("SUBCOMMAND", "COMMAND");
    column_width(30);
  }
  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override {
    std::string out = make_usage(app, name);
    if (!app->get_description().empty()) out += "\n" + app->get_description() + "\n";
    return out + make_positionals(app) + make_groups(app, mode) + make_subcommands(app, mode) + make_footer(app);
  }
  std::string make_option_opts(const CLI::Option* option) const override {
    return option->get_option_text().empty() ? "" : " " + option->get_option_text();
  }
};

}  // namespace

CommandLine::CommandLine(std::string name) : name_(std::move(name)), app_(std::make_unique<CLI::App>("", name_)) {
  app_->formatter(std::make_shared<HelpFormatter>());
  app_->set_help_flag("-h,--help", "print this help and exit");
  app_->set_version_flag("--version", Version(), "print the version and exit");
  // Unknown arguments are collected and refused by Parse, naming the first one.
  app_->allow_extras();
  // An option given twice: the last one counts.
  app_->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

CommandLine::~CommandLine() = default;

CommandLine& CommandLine::Description(const std::string& text) {
  app_->description(text);
  return *this;
}

CommandLine& CommandLine::Positional(const std::string& name, const std::string& help) {
  app_->add_option(name, values_[name], help)->required()->type_name(name);
  positional_names_.push_back(name);
  return *this;
}

CommandLine& CommandLine::Option(const std::string& name, const std::string& value, const std::string& help) {
  options_[name] = app_->add_option(name, values_[name], help)->type_name(value)->option_text(value);
  return *this;
}

CommandLine& CommandLine::Flag(const std::string& name, const std::string& help) {
  options_[name] = app_->add_flag(name, help);
  return *this;
}

CommandLine& CommandLine::Command(const std::string& name, const std::string& summary) {
  app_->add_subcommand(name, summary)->group("Commands");
  commands_.push_back(name);
  return *this;
}

CommandLine& CommandLine::Footer(const std::string& text) {
  app_->footer(text);
  return *this;
}

std::string CommandLine::Help() const { return app_->help(); }

int CommandLine::Refuse(const std::string& problem) const {
  std::cerr << name_ << ": error: command line: " << problem << " (see " << name_ << " --help)\n";
  return calib::kExitBadInput;
}

namespace {
// `arg` as a POSIX shell reads it back: single-quoted unless it holds only safe characters.
std::string ShellQuoted(const std::string& arg) {
  const bool safe = !arg.empty() && arg.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                          "0123456789@%+=:,./_-") == std::string::npos;
  if (safe) return arg;
  std::string out = "'";
  for (const char c : arg) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}
}  // namespace

std::optional<int> CommandLine::Parse(int argc, char** argv, int first) {
  as_run.clear();
  for (int i = 0; i < argc; ++i) as_run += (i ? " " : "") + ShellQuoted(argv[i]);
  std::vector<std::string> args(argv + std::min(first, argc), argv + argc);
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  // What CLI11 did not recognise: the first unknown option, else the first extra argument.
  auto unexpected = [&]() -> std::string {
    const std::vector<std::string> left = app_->remaining();
    for (const std::string& arg : left)
      if (arg.size() > 1 && arg[0] == '-') return arg + ": unknown option";
    if (left.empty()) return "";
    return left.front() + (commands_.empty() ? ": unexpected argument" : ": unknown command");
  };
  try {
    app_->parse(args);
  } catch (const CLI::CallForHelp&) {
    std::cout << Help();
    return calib::kExitOk;
  } catch (const CLI::CallForVersion&) {
    std::cout << name_ << " " << Version() << "\n";
    return calib::kExitOk;
  } catch (const CLI::ArgumentMismatch& e) {
    // The only mismatch a one-value option has: the command line ends before its value.
    const std::string what = e.what();
    const std::string option = what.substr(0, what.find(':'));
    return Refuse(options_.count(option) ? option + ": needs a value" : what);
  } catch (const CLI::ParseError& e) {
    const std::string problem = unexpected();
    return Refuse(problem.empty() ? e.what() : problem);
  }
  if (const std::string problem = unexpected(); !problem.empty()) return Refuse(problem);
  if (!commands_.empty()) {
    std::string names;
    for (const std::string& command : commands_) names += (names.empty() ? "" : ", ") + command;
    return Refuse("a command is needed: " + names);
  }
  positional.clear();
  for (const std::string& name : positional_names_) positional.push_back(values_.at(name));
  return std::nullopt;
}

bool CommandLine::Has(const std::string& option) const {
  const auto it = options_.find(option);
  if (it == options_.end()) throw std::logic_error(name_ + ": option " + option + " was not declared");
  return it->second->count() > 0;
}

std::string CommandLine::Get(const std::string& option, const std::string& fallback) const {
  return Has(option) ? values_.at(option) : fallback;
}

double CommandLine::GetDouble(const std::string& option, double fallback) const {
  if (!Has(option)) return fallback;
  const std::string& text = values_.at(option);
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0')
    throw calib::InputError("command line", option, "expected a number, got '" + text + "'");
  return v;
}

}  // namespace agvcal_process
