#pragma once
// Result files are written whole or not at all (spec/cli.md: never a partial
// result file): the text goes to PATH.partial, which is renamed to PATH.

#include <string>

namespace calib {

// Throws InputError naming `path` if it cannot be written; PATH is then untouched.
void WriteFileAtomically(const std::string& path, const std::string& text);

}  // namespace calib
