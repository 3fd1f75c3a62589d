// Fuzz target: a column map (JSON) and a kinematics table. Input = map text,
// a NUL byte, then the table text.
#include <cstdint>
#include <cstring>
#include <string>

#include "dentar/training/kinematics.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::training;
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
  const std::size_t n = nul ? static_cast<std::size_t>(nul - data) : size;
  const std::string map_text(reinterpret_cast<const char*>(data), n);
  const std::string table(reinterpret_cast<const char*>(data) + std::min(size, n + 1), size - std::min(size, n + 1));
  auto map = parse_column_map(map_text, "map.json");
  if (!map) return 0;
  auto t = parse_kinematics(table, "table.csv", *map);
  if (t && (t->x.cols() != static_cast<Eigen::Index>(t->feature_names.size()) || !(t->rate_hz > 0))) __builtin_trap();
  return 0;
}
