// Fuzz target: MetaImage headers and inline (.mha, ElementDataFile = LOCAL)
// data, raw or zlib-compressed. Detached-data headers decode the bytes after
// the header as if they were the data file.
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::volume;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::size_t header_bytes = 0;
  const auto h = parse_metaimage_header(text, "fuzz.mha", &header_bytes);
  if (h && header_bytes > size) __builtin_trap();  // parser contract
  const std::size_t off = h ? header_bytes : size;
  fuzz::decode_after_header(h, std::span<const std::uint8_t>(data + off, size - off), "fuzz.mha");
  return 0;
}
