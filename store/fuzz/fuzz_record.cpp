// Fuzz target: a stored session as JSON (outbox payloads, `dentar db export`).
#include <cstdint>
#include <nlohmann/json.hpp>

#include "dentar/store/record.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = nlohmann::json::parse(data, data + size, nullptr, false);
  if (j.is_discarded()) return 0;
  auto r = dentar::store::record_from_json(j);
  if (r) {
    auto again = dentar::store::record_from_json(dentar::store::to_json(*r));
    if (!again || again->key != r->key || again->metrics.size() != r->metrics.size()) __builtin_trap();
  }
  return 0;
}
