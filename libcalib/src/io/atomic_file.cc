#include "calib/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <system_error>

#include "calib/core/errors.h"

namespace calib {
namespace {

namespace fs = std::filesystem;

// Lists the files agvcal wrote into a report folder, with a hash of each: the next report
// replaces the folder only when nothing else is in it and none of them was changed.
const char* const kManifestName = ".agvcal-report";

std::string ErrnoText() { return std::strerror(errno); }

// `path` with symbolic links followed as far as they lead (a dangling link: the path it names),
// so that writing replaces the link's target and the link stays a link.
fs::path FollowLinks(const std::string& path) {
  fs::path p = path;
  for (int hops = 0; hops < 40; ++hops) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(p, ec))) break;
    const fs::path to = fs::read_symlink(p, ec);
    if (ec) break;
    p = to.is_absolute() ? to : p.parent_path() / to;
  }
  return p;
}

// `path` as the user will find it: a file in a report's staging folder by its place in the report.
std::string Shown(const std::string& path) {
  static const std::regex kStaging(R"(\.agvcal-[a-z0-9]{6}\.partial(/|$))");
  return std::regex_replace(path, kStaging, "$1");
}

// A folder named without a last component ("out/", ".") as one with it, for renaming.
fs::path FolderPath(const std::string& dir) {
  fs::path p = fs::absolute(FollowLinks(dir)).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p;
}

// The descriptor a path names (/dev/stdout, /dev/fd/N, /proc/self/fd/N), or -1: written
// through it, so that `--out /dev/stdout > FILE` appends to what the command prints.
int DescriptorNamed(const std::string& path) {
  if (path == "/dev/stdout") return 1;
  if (path == "/dev/stderr") return 2;
  for (const char* prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    const std::string p(prefix);
    if (path.size() > p.size() && path.compare(0, p.size(), p) == 0 &&
        path.find_first_not_of("0123456789", p.size()) == std::string::npos)
      return std::stoi(path.substr(p.size()));
  }
  return -1;
}

// An existing FIFO, device or socket: written in place, never replaced.
bool WrittenInPlace(const fs::path& target) {
  std::error_code ec;
  const fs::file_status s = fs::status(target, ec);
  return !ec && fs::exists(s) && !fs::is_regular_file(s) && !fs::is_directory(s);
}

fs::path ParentOf(const fs::path& p) { return p.parent_path().empty() ? fs::path(".") : p.parent_path(); }

// A name beside `target` that no file has: TARGET.agvcal-XXXXXX.partial (never a user's file).
std::string UniqueSibling(const fs::path& target) {
  thread_local std::mt19937_64 random(std::random_device{}() ^ static_cast<uint64_t>(::getpid()));
  static const char kLetters[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::string suffix(6, 'x');
  for (char& c : suffix) c = kLetters[random() % (sizeof(kLetters) - 1)];
  return (ParentOf(target) / (target.filename().string() + ".agvcal-" + suffix + ".partial")).string();
}

// Creates a new file beside `target` (O_EXCL: never one that exists); its name in *name.
int CreateUniqueFile(const fs::path& target, std::string* name) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    *name = UniqueSibling(target);
    const int fd = ::open(name->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0 || errno != EEXIST) return fd;
  }
  return -1;
}

std::string CreateUniqueFolder(const fs::path& target) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const std::string name = UniqueSibling(target);
    if (::mkdir(name.c_str(), 0777) == 0) return name;
    if (errno != EEXIST) break;
  }
  return "";
}

// Creates and removes a file of agvcal's own in `dir`; InputError naming `shown` if that fails.
void ProbeWritable(const fs::path& dir, const std::string& shown, const std::string& option) {
  std::string probe;
  const int fd = CreateUniqueFile(dir / "write-check", &probe);
  if (fd < 0) throw InputError(shown, option, "cannot write there: " + ErrnoText());
  ::close(fd);
  ::unlink(probe.c_str());
}

std::string ReadWhole(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// FNV-1a: tells a file agvcal wrote from one changed since.
std::string ContentHash(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

// The manifest of a report folder: file name -> hash (empty when there is none).
std::map<std::string, std::string> ReadManifest(const fs::path& dir) {
  std::map<std::string, std::string> files;
  std::ifstream in(dir / kManifestName);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t space = line.find(' ');
    if (line.empty() || line[0] == '#' || space == std::string::npos) continue;
    files[line.substr(space + 1)] = line.substr(0, space);
  }
  return files;
}

void WriteManifest(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir))
    if (e.is_regular_file()) files[e.path().filename().string()] = ContentHash(ReadWhole(e.path()));
  std::string text =
      "# The files agvcal wrote into this report folder (hash, name). The next --report into the\n"
      "# folder replaces it whole, and only while it holds nothing else (docs/reports.md).\n";
  for (const auto& [name, hash] : files) text += hash + " " + name + "\n";
  OutputFile manifest((dir / kManifestName).string());
  manifest.Write(text.data(), text.size());
  manifest.Commit();
}

// Swaps the finished report in `staging` in for `target` (a folder PrepareReportDir accepted):
// the previous report stays until the new one is in place.
void SwapInFolder(const std::string& staging, const fs::path& target, const std::string& shown) {
  std::error_code ec;
  if (!fs::exists(target, ec)) {
    if (std::rename(staging.c_str(), target.c_str()) != 0)
      throw InputError(shown, "", "cannot put the report in place: " + ErrnoText());
    return;
  }
  if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) != 0) {
    // No atomic exchange on this file system: move the old report aside, then the new one in.
    const std::string aside = CreateUniqueFolder(target);
    if (aside.empty() || std::rename(target.c_str(), aside.c_str()) != 0 ||
        std::rename(staging.c_str(), target.c_str()) != 0) {
      const std::string why = ErrnoText();
      if (!aside.empty() && !fs::exists(target, ec)) std::rename(aside.c_str(), target.c_str());
      if (!aside.empty()) ::rmdir(aside.c_str());
      throw InputError(shown, "", "cannot put the report in place: " + why);
    }
    fs::remove_all(aside, ec);
    return;
  }
  fs::remove_all(staging, ec);  // now the previous report
}

bool SameExistingFile(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return S_ISREG(sa.st_mode) && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

// Two outputs that do not exist yet, named differently (or through links).
bool SameNewPath(const std::string& a, const std::string& b) {
  std::error_code ea, eb;
  const fs::path pa = fs::weakly_canonical(fs::absolute(FollowLinks(a)), ea);
  const fs::path pb = fs::weakly_canonical(fs::absolute(FollowLinks(b)), eb);
  return !ea && !eb && !fs::exists(pa) && pa == pb;
}

}  // namespace

std::FILE* OpenOutput(const std::string& path, std::string* temporary) {
  temporary->clear();
  const fs::path target = FollowLinks(path);
  int fd;
  if (DescriptorNamed(path) >= 0) {
    std::fflush(stdout);  // what the command printed comes first
    fd = ::fcntl(DescriptorNamed(path), F_DUPFD_CLOEXEC, 3);
  } else if (WrittenInPlace(target)) {
    fd = ::open(target.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
  } else {
    fd = CreateUniqueFile(target, temporary);
    if (fd < 0) temporary->clear();
  }
  if (fd < 0) throw InputError(Shown(path), "", "cannot write: " + ErrnoText());
  std::FILE* file = ::fdopen(fd, "wb");
  if (!file) {
    const std::string why = ErrnoText();
    ::close(fd);
    if (!temporary->empty()) ::unlink(temporary->c_str());
    temporary->clear();
    throw InputError(Shown(path), "", "cannot write: " + why);
  }
  return file;
}

namespace {

// Flushes and closes; a temporary is synced first, so its data is on disk before the rename
// makes it the file. Throws InputError naming `path`.
void CloseOutput(const std::string& path, std::FILE* file, bool sync) {
  const bool flushed = std::fflush(file) == 0 && (!sync || ::fsync(::fileno(file)) == 0);
  const std::string why = ErrnoText();
  const bool closed = std::fclose(file) == 0;
  if (!flushed || !closed) throw InputError(Shown(path), "", "cannot write: " + (flushed ? ErrnoText() : why));
}

void PlaceOutput(const std::string& path, const std::string& temporary) {
  if (std::rename(temporary.c_str(), FollowLinks(path).c_str()) != 0)
    throw InputError(Shown(path), "", "cannot write: " + ErrnoText());
}

}  // namespace

void CommitOutput(const std::string& path, std::FILE* file, std::string* temporary) {
  try {
    CloseOutput(path, file, !temporary->empty());
    if (!temporary->empty()) PlaceOutput(path, *temporary);
  } catch (const InputError&) {
    if (!temporary->empty()) ::unlink(temporary->c_str());
    temporary->clear();
    throw;
  }
  temporary->clear();
}

OutputFile::OutputFile(const std::string& path) : path_(path), file_(OpenOutput(path, &temporary_)) {}

OutputFile::~OutputFile() {
  if (file_) std::fclose(file_);
  if (!temporary_.empty()) ::unlink(temporary_.c_str());
}

void OutputFile::Write(const void* data, std::size_t size) {
  if (!file_ || std::fwrite(data, 1, size, file_) != size)
    throw InputError(Shown(path_), "", "cannot write: " + ErrnoText());
}

void OutputFile::Finish() {
  if (!file_) return;
  std::FILE* file = file_;
  file_ = nullptr;
  CloseOutput(path_, file, !temporary_.empty());
}

void OutputFile::Commit() {
  Finish();
  if (temporary_.empty()) return;
  PlaceOutput(path_, temporary_);
  temporary_.clear();
}

Outputs::~Outputs() {
  std::error_code ec;
  for (const StagedDir& d : dirs_) fs::remove_all(d.staging, ec);
}

void Outputs::WriteFile(const std::string& path, const std::string& text) {
  if (DescriptorNamed(path) >= 0 || WrittenInPlace(FollowLinks(path))) {
    files_.push_back({path, nullptr, text});
    return;
  }
  auto file = std::make_unique<OutputFile>(path);
  file->Write(text.data(), text.size());
  file->Finish();
  files_.push_back({path, std::move(file), ""});
}

std::string Outputs::ReportDir(const std::string& dir) {
  PrepareReportDir(dir);
  const fs::path target = FolderPath(dir);
  const std::string staging = CreateUniqueFolder(target);
  if (staging.empty()) throw InputError(dir, "--report", "cannot write beside the folder: " + ErrnoText());
  dirs_.push_back({staging, target.string(), dir});
  return staging;
}

void Outputs::Commit() {
  for (const StagedDir& d : dirs_) {
    PrepareReportDir(d.shown);  // still nothing of the user's in it
    WriteManifest(d.staging);
  }
  for (Staged& f : files_)
    if (f.file) f.file->Commit();
  for (const StagedDir& d : dirs_) SwapInFolder(d.staging, d.target, d.shown);
  dirs_.clear();
  for (Staged& f : files_) {
    if (f.file) continue;
    OutputFile in_place(f.path);
    in_place.Write(f.text.data(), f.text.size());
    in_place.Commit();
  }
  files_.clear();
}

void WriteFileAtomically(const std::string& path, const std::string& text) {
  Outputs outputs;
  outputs.WriteFile(path, text);
  outputs.Commit();
}

void Outputs::AppendFile(const std::string& path, const std::string& text) {
  std::string existing;
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) existing = ReadWhole(path);  // never read a FIFO: it would wait
  WriteFile(path, existing + text);
}

void AppendFileAtomically(const std::string& path, const std::string& text) {
  Outputs outputs;
  outputs.AppendFile(path, text);
  outputs.Commit();
}

void CheckWritableFile(const std::string& path, const std::string& option) {
  std::error_code ec;
  if (DescriptorNamed(path) >= 0) return;
  const fs::path target = FollowLinks(path);
  if (fs::is_directory(target, ec))
    throw InputError(path, option, "is a folder; " + option + " takes a file name");
  if (WrittenInPlace(target)) return;  // a FIFO or device: written in place
  const fs::path parent = ParentOf(target);
  if (!fs::is_directory(parent, ec))
    throw InputError(path, option, "its folder " + parent.string() + " does not exist");
  ProbeWritable(parent, path, option);
}

void PrepareReportDir(const std::string& dir, const std::string& option) {
  std::error_code ec;
  const fs::path target = FolderPath(dir);
  if (fs::exists(target, ec) && !fs::is_directory(target, ec))
    throw InputError(dir, option, "exists and is not a folder; " + option + " takes a folder (created if missing)");
  const fs::path parent = ParentOf(target);
  fs::create_directories(parent, ec);
  if (ec) throw InputError(dir, option, "cannot create the folder: " + ec.message());
  ProbeWritable(parent, dir, option);  // the report is written beside the folder, then swapped in
  if (!fs::exists(target, ec)) return;
  // Only a report agvcal wrote is replaced; anything else in the folder is the user's.
  const std::map<std::string, std::string> ours = ReadManifest(target);
  for (const fs::directory_entry& e : fs::directory_iterator(target, ec)) {
    const std::string name = e.path().filename().string();
    if (name == kManifestName) continue;
    const auto listed = ours.find(name);
    if (listed == ours.end() || !e.is_regular_file())
      throw InputError(dir, name, "was not written by agvcal; a report replaces its folder whole, so choose a new or "
                                  "empty folder, or move the file away");
    if (listed->second != ContentHash(ReadWhole(e.path())))
      throw InputError(dir, name, "was changed since agvcal wrote it; a report replaces its folder whole, so choose "
                                  "a new or empty folder, or move the file away");
  }
  if (ec) throw InputError(dir, option, "cannot read the folder: " + ec.message());
}

void MakeReportDir(const std::string& dir) {
  PrepareReportDir(dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir, "--report", "cannot make the folder: " + ec.message());
}

void CheckOutputs(const std::vector<std::string>& inputs, const std::vector<OutputTarget>& outputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const OutputTarget& out = outputs[i];
    if (out.path.empty()) continue;
    for (const std::string& input : inputs) {
      if (!input.empty() && SameExistingFile(out.path, input))
        throw InputError(out.path, out.option, "is the input " + input +
                                                   " (the same file); agvcal never writes over an input, choose "
                                                   "another output file");
    }
    for (std::size_t j = 0; j < i; ++j) {
      const OutputTarget& other = outputs[j];
      if (!other.path.empty() && (SameExistingFile(out.path, other.path) || SameNewPath(out.path, other.path)))
        throw InputError(out.path, out.option, "is also the output of " + other.option + " (" + other.path +
                                                   "); give each output its own file");
    }
    if (out.folder)
      PrepareReportDir(out.path, out.option);
    else
      CheckWritableFile(out.path, out.option);
  }
}

}  // namespace calib
