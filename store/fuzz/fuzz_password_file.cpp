// Fuzz target: the instructor password file parser.
#include <cstdint>
#include <string_view>

#include "dentar/store/auth.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto r = dentar::store::parse_password_file(std::string_view(reinterpret_cast<const char*>(data), size));
  if (r) {
    // What parses, formats and parses back to the same entries.
    auto again = dentar::store::parse_password_file(dentar::store::format_password_file(*r));
    if (!again || again->size() != r->size()) __builtin_trap();
  }
  return 0;
}
