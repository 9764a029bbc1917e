#include "calib/core/errors.h"

#include <exception>
#include <iostream>

namespace calib {

namespace {
std::string JoinPlace(const std::string& file, const std::string& place, const std::string& problem) {
  std::string out = file;
  if (!place.empty()) out += (out.empty() ? "" : ": ") + place;
  return out + (out.empty() ? "" : ": ") + problem;
}
}  // namespace

InputError::InputError(std::string file, std::string place, std::string problem)
    : std::runtime_error(JoinPlace(file, place, problem)),
      file_(std::move(file)),
      place_(std::move(place)),
      problem_(std::move(problem)) {}

UnobservableError::UnobservableError(std::string what_is_unobservable, std::string remedy)
    : std::runtime_error(what_is_unobservable + "; " + remedy), remedy_(std::move(remedy)) {}

int RunMain(const char* program, int (*body)(int, char**), int argc, char** argv) {
  try {
    return body(argc, argv);
  } catch (const InputError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const UnobservableError& e) {
    std::cerr << program << ": cannot determine: " << e.what() << "\n";
    return kExitUnobservable;
  } catch (const std::exception& e) {
    std::cerr << program << ": internal error: " << e.what() << "\n";
    return kExitInternal;
  }
}

}  // namespace calib
