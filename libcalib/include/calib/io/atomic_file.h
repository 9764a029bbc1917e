#pragma once
// The one place where agvcal writes its outputs (spec/cli.md: never a partial result file;
// docs/bad-input.md, "Outputs"). A result file is written to a temporary with a unique name
// beside it and renamed over it, so a reader sees the old file or the new one; a report folder
// is written as a whole new folder beside it and swapped in. A symbolic link given as an output
// stays a link: its target is replaced. A FIFO or a device is written in place (streamed),
// /dev/stdout, /dev/fd/N and /proc/self/fd/N through that descriptor.
// Nothing but the temporaries agvcal made is ever removed.

#include <cstddef>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace calib {

// One output of a command, for CheckOutputs: `option` names it in messages ("--out", or
// "OUT.log" for a positional argument); an empty `path` is an output not asked for.
struct OutputTarget {
  std::string option;
  std::string path;
  bool folder = false;  // a report folder (--report DIR)
};

// Checks every output of a command before the work starts, so that a mistake costs no run
// and loses nothing: throws InputError (exit 2, one line naming both) when an output is the
// same file as an input (also through a hard or a symbolic link) or as another output; and
// when a file output cannot be written (CheckWritableFile) or a report folder cannot be
// replaced (PrepareReportDir).
void CheckOutputs(const std::vector<std::string>& inputs, const std::vector<OutputTarget>& outputs);

// Checks before the work starts that a result file can be written at `path` (`option` names
// the command-line option in the message): not a folder, its folder exists and takes files.
// Throws InputError naming the path (exit 2) instead of failing after the analysis.
void CheckWritableFile(const std::string& path, const std::string& option);

// Checks before the work starts that DIR can take a human report (--report): missing (its
// parent folders are created), or an empty folder, or a report agvcal wrote, all of whose
// files agvcal listed in its manifest (.agvcal-report). A folder holding anything else (the
// user's own files, an older report without a manifest) is refused, never cleared: the
// report replaces the folder whole. Throws InputError naming DIR and the first file that is
// not agvcal's (exit 2). Changes nothing in DIR.
void PrepareReportDir(const std::string& dir, const std::string& option = "--report");

// What a report writer calls first: PrepareReportDir, then DIR made if it is missing, so a
// writer called directly (not into Outputs' staged folder) writes into a folder that exists.
void MakeReportDir(const std::string& dir);

// One output file written whole or not at all: a regular (or new) file is written to a
// temporary beside it (beside a symbolic link's target), which Commit() renames over it; a
// FIFO or a device is written in place. Without Commit() the temporary is removed and the
// previous file stays. Write errors (a full disk) throw InputError naming the path.
class OutputFile {
 public:
  explicit OutputFile(const std::string& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void Write(const void* data, std::size_t size);
  // Flushes and closes the temporary (its data on disk); the target is still untouched.
  void Finish();
  // Finish(), then puts the file in place.
  void Commit();
  const std::string& path() const { return path_; }

 private:
  std::string path_;       // as given
  std::string temporary_;  // empty: written in place
  std::FILE* file_ = nullptr;  // null once finished
};

// OutputFile's steps for a writer that keeps its own FILE* (LogWriter): opens the file `path`
// is written through, a new temporary beside its target (named in *temporary) or, for a FIFO
// or a device, the target itself (*temporary empty); InputError naming `path` if it cannot.
std::FILE* OpenOutput(const std::string& path, std::string* temporary);
// Closes `file` (its data on disk) and puts the temporary in place; on failure removes the
// temporary (PATH stays as it was) and throws InputError. *temporary is emptied.
void CommitOutput(const std::string& path, std::FILE* file, std::string* temporary);

// The outputs of one command, put in place together by Commit() only when all were written:
// when the command fails before (an exception), none of them replaces a previous one, and
// every temporary is removed.
class Outputs {
 public:
  Outputs() = default;
  ~Outputs();
  Outputs(const Outputs&) = delete;
  Outputs& operator=(const Outputs&) = delete;

  // Writes `text` to a temporary for `path` now (a FIFO or device: kept until Commit).
  void WriteFile(const std::string& path, const std::string& text);
  // WriteFile with PATH's present content (if it is a regular file) followed by `text`.
  void AppendFile(const std::string& path, const std::string& text);
  // A new empty folder beside `dir` to write the report into; Commit() swaps it in for `dir`.
  std::string ReportDir(const std::string& dir);
  void Commit();

 private:
  struct Staged {
    std::string path;
    std::unique_ptr<OutputFile> file;  // null: a FIFO or device, `text` written at Commit()
    std::string text;
  };
  struct StagedDir {
    std::string staging, target, shown;  // shown: the folder as the user named it
  };
  std::vector<Staged> files_;
  std::vector<StagedDir> dirs_;
};

// Writes one file through Outputs (for a command with a single output); InputError naming
// `path` if it cannot be written, and PATH is then untouched.
void WriteFileAtomically(const std::string& path, const std::string& text);

// Appends `text` to PATH (created if missing) through WriteFileAtomically: a reader sees the
// file with all of `text` or none of it (for logs of a few hundred lines; the file is rewritten).
void AppendFileAtomically(const std::string& path, const std::string& text);

}  // namespace calib
