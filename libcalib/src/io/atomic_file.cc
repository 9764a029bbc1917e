#include "calib/io/atomic_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>

#include "calib/core/errors.h"

namespace calib {

void WriteFileAtomically(const std::string& path, const std::string& text) {
  const std::string partial = path + ".partial";
  std::FILE* file = std::fopen(partial.c_str(), "wb");
  if (!file) throw InputError(path, "", std::string("cannot write: ") + std::strerror(errno));
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed || std::rename(partial.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(partial.c_str());
    throw InputError(path, "", "cannot write: " + why);
  }
}

void AppendFileAtomically(const std::string& path, const std::string& text) {
  std::string existing;
  std::ifstream in(path, std::ios::binary);
  if (in) {
    std::ostringstream buffer;
    buffer << in.rdbuf();
    existing = buffer.str();
  }
  WriteFileAtomically(path, existing + text);
}

namespace {

// Creates and removes a probe file in `dir`; InputError naming `shown` if that fails.
void ProbeWritable(const std::string& dir, const std::string& shown, const std::string& option) {
  const std::string probe = (std::filesystem::path(dir) / ".agvcal-write-check").string();
  std::FILE* file = std::fopen(probe.c_str(), "wb");
  if (!file) throw InputError(shown, option, std::string("cannot write there: ") + std::strerror(errno));
  std::fclose(file);
  std::remove(probe.c_str());
}

}  // namespace

void CheckWritableFile(const std::string& path, const std::string& option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError(path, option, "is a folder; " + option + " takes a file name");
  const fs::path parent = fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  if (!fs::is_directory(parent, ec))
    throw InputError(path, option, "its folder " + parent.string() + " does not exist");
  ProbeWritable(parent.string(), path, option);
}

void PrepareReportDir(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw InputError(dir, "", "exists and is not a directory (the report is a folder)");
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir, "", "cannot create the report folder: " + ec.message());
  // A previous report (an index.html titled "agvcal ...") is cleared; a folder with another
  // index.html is someone else's page and is left alone.
  const fs::path index = fs::path(dir) / "index.html";
  if (fs::exists(index, ec)) {
    std::ifstream in(index);
    std::string head(4096, '\0');
    in.read(&head[0], static_cast<std::streamsize>(head.size()));
    if (head.find("<title>agvcal") == std::string::npos)
      throw InputError(dir, "index.html", "holds a page that is not an agvcal report; choose another folder");
    std::vector<fs::path> ours;
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      if (e.is_regular_file() && (name == "index.html" || name == "summary.txt" || e.path().extension() == ".svg"))
        ours.push_back(e.path());
    }
    if (ec) throw InputError(dir, "", "cannot read the report folder: " + ec.message());
    for (const fs::path& p : ours) {
      fs::remove(p, ec);
      if (ec) throw InputError(dir, p.filename().string(), "cannot remove the previous report's file: " + ec.message());
    }
  }
  // Writable? WriteFileAtomically would say so too, but only after the analysis.
  ProbeWritable(dir, dir, "");
}

}  // namespace calib
