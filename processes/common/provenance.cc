#include "common/provenance.h"

#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <ctime>
#include <fstream>
#include <memory>
#include <vector>

#include "calib/core/errors.h"
#include "calib/io/provenance.h"

namespace agvcal_process {

std::string FileSha256(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw calib::InputError(path, "file", "cannot read it");
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr);
  std::vector<char> buffer(1 << 16);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    EVP_DigestUpdate(ctx.get(), buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_DigestFinal_ex(ctx.get(), digest, &size);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < size; ++i) out += {hex[digest[i] >> 4], hex[digest[i] & 15]};
  return out;
}

void RecordProvenance(const CommandLine& args, const calib::RobotDescription* robot, const std::string& recording) {
  calib::Provenance p;
  p.command = args.as_run;
  std::vector<char> cwd(4096);
  if (getcwd(cwd.data(), cwd.size())) p.directory = cwd.data();
  p.version = Version();
  std::time_t now = std::time(nullptr);
  if (const char* epoch = std::getenv("SOURCE_DATE_EPOCH")) now = static_cast<std::time_t>(std::atoll(epoch));
  std::tm utc{};
  gmtime_r(&now, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &utc);
  p.date = date;
  if (robot) p.robot_name = robot->name, p.robot_file = robot->source_file;
  if (!recording.empty()) {
    p.recording = recording;
    // Only a regular file is hashed: reading a FIFO or a device again would block or take the
    // data the command itself reads, so their provenance names them without a hash.
    struct stat st {};
    if (stat(recording.c_str(), &st) == 0 && S_ISREG(st.st_mode)) p.recording_sha256 = FileSha256(recording);
  }
  calib::SetRunProvenance(p);
}

}  // namespace agvcal_process
