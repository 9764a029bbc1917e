// Outputs are written whole or not at all, never over an input, never over a user's file
// (calib/io/atomic_file.h; docs/bad-input.md, "Outputs").
#include "calib/io/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "calib/core/errors.h"
#include "calib/io/recording.h"

namespace calib {
namespace {

namespace fs = std::filesystem;

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("agvcal_atomic_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // Every entry of the test folder (recursively): nothing is left behind, nothing lost.
  std::vector<std::string> Entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) names.push_back(e.path().lexically_relative(dir_).string());
    std::sort(names.begin(), names.end());
    return names;
  }
  fs::path dir_;
};

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// Writes beyond `bytes` fail (EFBIG) as on a full disk, while the object lives.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    ::getrlimit(RLIMIT_FSIZE, &saved_);
    previous_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    ::setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, previous_);
  }

 private:
  rlimit saved_{};
  void (*previous_)(int);
};

TEST_F(AtomicFileTest, AnOutputThatIsAnInputIsRefusedThroughLinks) {
  const std::string log = Path("run.log"), hard = Path("hard.log"), soft = Path("soft.log");
  WriteText(log, "recording\n");
  ASSERT_EQ(::link(log.c_str(), hard.c_str()), 0);
  ASSERT_EQ(::symlink("run.log", soft.c_str()), 0);
  for (const std::string& out : {log, hard, soft}) {
    try {
      CheckOutputs({Path("robot.yaml"), log}, {{"--out", out}});
      ADD_FAILURE() << out << " accepted as an output";
    } catch (const InputError& e) {
      const std::string line = e.what();
      EXPECT_NE(line.find(out), std::string::npos) << line;  // names both
      EXPECT_NE(line.find("is the input " + log), std::string::npos) << line;
      EXPECT_NE(line.find("--out"), std::string::npos) << line;
    }
  }
  EXPECT_EQ(ReadText(log), "recording\n");
  // Two outputs into one file, also before either exists.
  EXPECT_THROW(CheckOutputs({log}, {{"--out", Path("a.json")}, {"--write-robot", Path("a.json")}}), InputError);
  EXPECT_NO_THROW(CheckOutputs({log}, {{"--out", Path("a.json")}, {"--write-robot", Path("b.yaml")}, {"--report", ""}}));
}

TEST_F(AtomicFileTest, AFailedCommandReplacesNoPreviousOutput) {
  const std::string result = Path("RESULT.json"), robot = Path("cal.yaml");
  WriteText(result, "previous result\n");
  WriteText(robot, "previous robot\n");
  {
    Outputs outputs;
    outputs.WriteFile(result, "new result\n");
    outputs.WriteFile(robot, "new robot\n");
    // The command fails here (no Commit).
  }
  EXPECT_EQ(ReadText(result), "previous result\n");
  EXPECT_EQ(ReadText(robot), "previous robot\n");
  EXPECT_EQ(Entries(), (std::vector<std::string>{"RESULT.json", "cal.yaml"}));
  Outputs outputs;
  outputs.WriteFile(result, "new result\n");
  outputs.WriteFile(robot, "new robot\n");
  outputs.Commit();
  EXPECT_EQ(ReadText(result), "new result\n");
  EXPECT_EQ(ReadText(robot), "new robot\n");
}

TEST_F(AtomicFileTest, AFullDiskLeavesThePreviousFilesAndNoTemporary) {
  const std::string result = Path("RESULT.json"), robot = Path("cal.yaml");
  WriteText(result, "previous result\n");
  WriteText(robot, "previous robot\n");
  {
    const FileSizeLimit full(4096);
    Outputs outputs;
    outputs.WriteFile(result, "small result\n");
    EXPECT_THROW(outputs.WriteFile(robot, std::string(100000, 'x')), InputError);
    EXPECT_THROW(WriteFileAtomically(result, std::string(100000, 'x')), InputError);
  }
  EXPECT_EQ(ReadText(result), "previous result\n");
  EXPECT_EQ(ReadText(robot), "previous robot\n");
  EXPECT_EQ(Entries(), (std::vector<std::string>{"RESULT.json", "cal.yaml"}));
}

TEST_F(AtomicFileTest, AUsersFilesBesideTheOutputAreNeverTouched) {
  const std::string out = Path("OUT.json");
  WriteText(out + ".partial", "the user's\n");
  WriteText(Path(".agvcal-write-check"), "the user's too\n");
  CheckWritableFile(out, "--out");
  WriteFileAtomically(out, "result\n");
  AppendFileAtomically(out, "more\n");
  LogWriter log(Path("rec.log"));
  WriteText(Path("rec.log.partial"), "the user's log\n");
  log.Close();
  EXPECT_EQ(ReadText(out), "result\nmore\n");
  EXPECT_EQ(ReadText(out + ".partial"), "the user's\n");
  EXPECT_EQ(ReadText(Path(".agvcal-write-check")), "the user's too\n");
  EXPECT_EQ(ReadText(Path("rec.log.partial")), "the user's log\n");
}

TEST_F(AtomicFileTest, ASymbolicLinkStaysALinkAndItsTargetIsReplaced) {
  fs::create_directories(dir_ / "real");
  const std::string target = Path("real/RESULT.json"), link = Path("RESULT.json");
  WriteText(target, "previous\n");
  ASSERT_EQ(::symlink("real/RESULT.json", link.c_str()), 0);
  CheckOutputs({}, {{"--out", link}});
  WriteFileAtomically(link, "new\n");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(ReadText(target), "new\n");
  // A dangling link: its target is created.
  ASSERT_EQ(::symlink("real/new.json", Path("new.json").c_str()), 0);
  WriteFileAtomically(Path("new.json"), "created\n");
  EXPECT_TRUE(fs::is_symlink(Path("new.json")));
  EXPECT_EQ(ReadText(Path("real/new.json")), "created\n");
  EXPECT_EQ(Entries(), (std::vector<std::string>{"RESULT.json", "new.json", "real", "real/RESULT.json", "real/new.json"}));
}

TEST_F(AtomicFileTest, AFifoAndADeviceAreWrittenInPlace) {
  const std::string fifo = Path("results.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = ReadText(fifo); });
  CheckOutputs({}, {{"--out", fifo}});
  WriteFileAtomically(fifo, "streamed\n");
  reader.join();
  EXPECT_EQ(received, "streamed\n");
  EXPECT_TRUE(fs::is_fifo(fifo));

  // A null device of our own (as root); elsewhere a symbolic link to /dev/null.
  std::string null_device = Path("null");
  if (::mknod(null_device.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) {
    null_device = Path("null-link");
    ASSERT_EQ(::symlink("/dev/null", null_device.c_str()), 0);
  }
  WriteFileAtomically(null_device, "discarded\n");
  LogWriter log(null_device);
  log.Publish("WHEELS", 1, {1, 2, 3});
  log.Close();
  EXPECT_TRUE(fs::is_character_file(null_device));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

// A report folder as the report writers make one: index.html, summary.txt, plots.
void WriteReport(const std::string& dir, const std::string& title) {
  WriteFileAtomically(dir + "/index.html", "<title>agvcal " + title + "</title>\n");
  WriteFileAtomically(dir + "/summary.txt", title + "\n");
  WriteFileAtomically(dir + "/" + title + ".svg", "<svg/>\n");
}

TEST_F(AtomicFileTest, AReportFolderIsSwappedInWhole) {
  const std::string report = Path("report");
  {
    Outputs outputs;
    WriteReport(outputs.ReportDir(report), "first");
    EXPECT_FALSE(fs::exists(report));  // not before the command succeeded
    outputs.Commit();
  }
  EXPECT_EQ(ReadText(report + "/summary.txt"), "first\n");
  {
    Outputs outputs;
    WriteReport(outputs.ReportDir(report), "second");
    EXPECT_EQ(ReadText(report + "/summary.txt"), "first\n");  // the previous one kept until the swap
  }  // the command failed: no swap
  EXPECT_EQ(ReadText(report + "/summary.txt"), "first\n");
  EXPECT_TRUE(fs::exists(report + "/first.svg"));
  Outputs outputs;
  WriteReport(outputs.ReportDir(report), "second");
  outputs.Commit();
  EXPECT_EQ(ReadText(report + "/summary.txt"), "second\n");
  EXPECT_FALSE(fs::exists(report + "/first.svg"));
  EXPECT_EQ(Entries(), (std::vector<std::string>{"report", "report/.agvcal-report", "report/index.html",
                                                 "report/second.svg", "report/summary.txt"}));
}

TEST_F(AtomicFileTest, AReportFolderWithTheUsersFilesIsRefusedAndKept) {
  const std::string report = Path("report");
  Outputs first;
  WriteReport(first.ReportDir(report), "first");
  first.Commit();
  WriteText(report + "/my_plot.svg", "<svg>mine</svg>\n");
  try {
    PrepareReportDir(report);
    ADD_FAILURE() << "a folder with the user's plot accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("my_plot.svg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(CheckOutputs({}, {{"--report", report, true}}), InputError);
  fs::remove(report + "/my_plot.svg");
  WriteText(report + "/index.html", "<title>agvcal first</title>\n<p>my notes</p>\n");  // edited by the user
  EXPECT_THROW(PrepareReportDir(report), InputError);
  EXPECT_EQ(ReadText(report + "/index.html"), "<title>agvcal first</title>\n<p>my notes</p>\n");
  EXPECT_TRUE(fs::exists(report + "/first.svg"));
  // A folder of the user's with only plots in it (no agvcal report): refused, nothing removed.
  fs::create_directories(dir_ / "plots");
  WriteText(Path("plots/a.svg"), "<svg/>\n");
  EXPECT_THROW(PrepareReportDir(Path("plots")), InputError);
  EXPECT_EQ(ReadText(Path("plots/a.svg")), "<svg/>\n");
  // An empty folder takes a report.
  fs::create_directories(dir_ / "empty");
  Outputs outputs;
  WriteReport(outputs.ReportDir(Path("empty/")), "new");
  outputs.Commit();
  EXPECT_EQ(ReadText(Path("empty/summary.txt")), "new\n");
}

TEST_F(AtomicFileTest, AReportFolderThroughALinkReplacesTheLinksTarget) {
  const std::string real = Path("real"), link = Path("report");
  Outputs first;
  WriteReport(first.ReportDir(real), "first");
  first.Commit();
  ASSERT_EQ(::symlink("real", link.c_str()), 0);
  Outputs outputs;
  WriteReport(outputs.ReportDir(link), "second");
  outputs.Commit();
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(ReadText(real + "/summary.txt"), "second\n");
}

}  // namespace
}  // namespace calib
