// libFuzzer target: any bytes given to the state-file reader end in a State or a StateFileError.
// Inputs whose checksum is wrong are rejected early, so the target also re-signs the payload half of the
// time: that lets the fuzzer reach the field validation behind the checksum.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "io/state_file.hpp"

namespace {
std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t h = 1469598103934665603ULL;
  for (std::size_t k = 0; k < size; ++k) h = (h ^ static_cast<unsigned char>(data[k])) * 1099511628211ULL;
  return h;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  constexpr std::size_t kHeader = 8 + 4 + 8;  // magic, version, payload size
  if (size > kHeader + 8 && (data[size - 1] & 1)) {
    const std::size_t payload = size - kHeader - 8;
    std::memcpy(&bytes[12], &payload, 8);
    const std::uint64_t sum = fnv1a(bytes.data() + kHeader, payload);
    std::memcpy(&bytes[size - 8], &sum, 8);
  }
  try {
    (void)celldem::parse_state(bytes);
  } catch (const celldem::StateFileError&) {
  }
  return 0;
}
