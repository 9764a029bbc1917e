#pragma once
// Error types that carry what a user needs to fix the input, and the exit
// statuses of spec/cli.md. Every main catches these at the top and turns them
// into one line on stderr (see FormatError) and the documented exit status.

#include <stdexcept>
#include <string>

namespace calib {

// Exit statuses of spec/cli.md.
constexpr int kExitOk = 0;
constexpr int kExitInternal = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitUnobservable = 3;

// Unusable input: unreadable or corrupt file, missing channel, robot file error.
// `file` names the input, `place` where in it (e.g. "line 7, key params.wheelbase"
// or "event 1042 (byte 88231)"), `problem` what is wrong.
class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string place, std::string problem);
  const std::string& file() const { return file_; }
  const std::string& place() const { return place_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_, place_, problem_;
};

// The data cannot determine the answer: names what is unobservable and the
// motion (or data) that would fix it.
class UnobservableError : public std::runtime_error {
 public:
  UnobservableError(std::string what_is_unobservable, std::string remedy);
  const std::string& remedy() const { return remedy_; }

 private:
  std::string remedy_;
};

// Runs `body` and maps exceptions to one line on stderr, prefixed with the
// program name, and the exit status of spec/cli.md. For use at the top of main().
int RunMain(const char* program, int (*body)(int, char**), int argc, char** argv);

}  // namespace calib
