// The human report of the diagnosis: summary.txt and SVG plots.

#include <filesystem>

#include "calib/atomic_file.h"
#include "calib/diagnose.h"

namespace calib {

void WriteDiagnoseReportDir(const DiagnoseReport& report, const std::string& dir) {
  std::filesystem::create_directories(dir);
  WriteFileAtomically(dir + "/summary.txt", DiagnoseSummaryText(report));
}

}  // namespace calib
