#include "tests/support/test_data.h"

#include <cstdlib>

namespace scanprep::testing {

std::filesystem::path SharedDataDir() {
  const char* env = std::getenv("SCANPREP_DATA_DIR");
  std::filesystem::path dir = env != nullptr ? env : SCANPREP_SHARED_DATA;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return {};
  return std::filesystem::weakly_canonical(dir, ec);
}

}  // namespace scanprep::testing
