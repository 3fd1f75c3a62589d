// Fuzz target: the database URL parser (sqlite:PATH, postgresql://...).
#include <cstdint>
#include <string_view>

#include "dentar/store/db_url.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  auto r = dentar::store::parse_db_url(in);
  if (r && r->kind == dentar::store::DbUrl::Kind::Postgres) {
    // A password in the authority never reaches the redacted form.
    const std::string_view rest = in.substr(in.find("://") + 3);
    const std::string_view authority = rest.substr(0, rest.find('/'));
    const std::size_t at = authority.rfind('@');
    if (at != std::string_view::npos && authority.substr(0, at).find(':') != std::string_view::npos &&
        r->redacted.find(":***@") == std::string::npos)
      __builtin_trap();
  }
  return 0;
}
