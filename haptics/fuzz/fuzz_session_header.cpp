// Fuzz target: parse_session_header (the session log's JSON header, which
// replay trusts to rebuild the engine) on arbitrary text. It must return a
// setup or an error naming a field, never crash or throw.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "dentar/haptics/replay.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto r = dentar::haptics::parse_session_header(text);
  if (!r.ok() && r.error().rfind("session header", 0) != 0) std::abort();  // errors say where
  if (r.ok() && !r->engine.validate().empty()) std::abort();  // accepted setups are valid
  return 0;
}
