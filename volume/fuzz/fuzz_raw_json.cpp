// Fuzz target: the raw + JSON sidecar header. Input = sidecar text, then an
// optional NUL byte followed by the bytes of the (normally detached) data file.
#include <algorithm>
#include <cstring>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::volume;
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
  const std::size_t text_len = nul ? static_cast<std::size_t>(nul - data) : size;
  const std::string_view text(reinterpret_cast<const char*>(data), text_len);
  const auto h = parse_raw_json_header(text, "fuzz.json");
  const std::span<const std::uint8_t> rest(data + std::min(size, text_len + 1),
                                           size - std::min(size, text_len + 1));
  fuzz::decode_after_header(h, rest, "fuzz.raw");
  return 0;
}
