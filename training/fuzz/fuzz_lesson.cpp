// Fuzz target: the lesson parser (lesson.json, issue 27), then its writer: whatever parses
// must write back to text that parses again (mm/deg to SI and back may move the last bit, so
// the texts are not compared).
#include <cstdint>
#include <string>

#include "dentar/training/lesson.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar;
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto l = training::parse_lesson(text, "fuzz.json");
  if (!l) return 0;
  const std::string out = training::lesson_json(*l);
  auto again = training::parse_lesson(out, "again.json");
  if (!again || again->annotations.size() != l->annotations.size() || again->recording_hash != l->recording_hash)
    __builtin_trap();
  return 0;
}
