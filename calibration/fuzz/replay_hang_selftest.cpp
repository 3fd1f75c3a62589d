// Self-test of the replay drivers' per-input time limit (tests/fuzzutil/fuzz_replay.h): this
// target never returns on an input starting with "HANG", as a parser stuck in a loop would.
// The ctest replay_hang_selftest runs it through text_replay_main.cpp with a 1 s limit and
// passes only when the driver reports the hang and names the input.
#include <cstdint>
#include <cstring>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size >= 4 && std::memcmp(data, "HANG", 4) == 0) {
    volatile unsigned long spin = 0;
    for (;;) spin = spin + 1;
  }
  return 0;
}
