#pragma once
// Result files are written whole or not at all (spec/cli.md: never a partial
// result file): the text goes to PATH.partial, which is renamed to PATH.

#include <string>

namespace calib {

// Throws InputError naming `path` if it cannot be written; PATH is then untouched.
void WriteFileAtomically(const std::string& path, const std::string& text);

// Appends `text` to PATH (created if missing) through WriteFileAtomically: a reader sees the
// file with all of `text` or none of it (for logs of a few hundred lines; the file is rewritten).
void AppendFileAtomically(const std::string& path, const std::string& text);

// Checks before the work starts that a result file can be written at `path` (`option` names
// the command-line option in the message): not a folder, its folder exists and takes files.
// Throws InputError naming the path (exit 2) instead of failing after the analysis.
void CheckWritableFile(const std::string& path, const std::string& option);

// Makes DIR ready for a report: created when missing; when it holds a previous agvcal report
// (an index.html titled "agvcal ..."), that report's files (index.html, summary.txt, *.svg) are
// removed, so that none of them is taken for this run's. Throws InputError naming DIR when it
// is a file, holds an index.html that is not an agvcal report, or cannot be created, cleared or
// written.
void PrepareReportDir(const std::string& dir);

}  // namespace calib
