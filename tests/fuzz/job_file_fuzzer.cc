// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the CLI's job-file reader (client::ReadJobFile, protobuf JSON into JobHeader
// with unknown fields rejected), then the server's header validation (JobAssembler) on whatever
// parsed. ReadJobFile takes a path, so each input is written to an in-memory file (memfd) and
// read back through /proc/self/fd: the real reader runs unchanged, without touching the disk.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include <google/protobuf/stubs/logging.h>

#include "client/job_file.h"
#include "server/job/job_assembler.h"
#include "tests/fuzz/fuzz_checks.h"

namespace {

struct MemFile {
  int fd = memfd_create("job.json", 0);
  std::string path = "/proc/self/fd/" + std::to_string(fd);
};

}  // namespace

// protobuf logs every invalid UTF-8 string it parses; at thousands of inputs a second that is
// noise and slows the fuzzer down.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const MemFile file;
  scanprep::fuzz::Require(file.fd >= 0, "memfd_create works");
  scanprep::fuzz::Require(
      ftruncate(file.fd, 0) == 0 && pwrite(file.fd, data, size, 0) == static_cast<ssize_t>(size),
      "the job file is written");
  auto header = scanprep::client::ReadJobFile(file.path);
  if (!header.ok()) return 0;
  scanprep::v1::ProcessRequest request;
  *request.mutable_header() = *std::move(header);
  scanprep::server::JobAssembler assembler(scanprep::server::JobLimits{});
  (void)assembler.Add(request);
  return 0;
}
