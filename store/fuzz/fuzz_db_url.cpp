// Fuzz target: the database URL parser (sqlite:PATH, postgresql://...).
#include <cstdint>
#include <string_view>

#include "dentar/store/db_url.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto r = dentar::store::parse_db_url(std::string_view(reinterpret_cast<const char*>(data), size));
  if (r) {
    // The redacted form never shows a password.
    if (r->kind == dentar::store::DbUrl::Kind::Postgres && r->redacted.find('@') != std::string::npos &&
        r->uri.find(":secret@") != std::string::npos && r->redacted.find("secret") != std::string::npos)
      __builtin_trap();
  }
  return 0;
}
