// Replay driver for the session-log fuzz target without libFuzzer: runs every
// file of a corpus directory, then N deterministic mutations of them. The
// mutations suit a binary, length-prefixed format: bit flips, random bytes,
// truncation, insertion, deletion, duplicated spans (repeated blocks),
// splices of two corpus files, and 32-bit fields overwritten with values on
// the limits the reader checks. A crash, sanitizer report or trap is the
// failure signal; the exit code is 0 otherwise.
//   usage: <target>_replay <corpus dir> [--mutations N] [--seed S]
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string_view>
#include <vector>

#include "fuzz_replay.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

using dentar::fuzz::Bytes;
using dentar::fuzz::Rng;

// Counts, lengths and versions around the reader's limits (208-byte records,
// 2^16 records per block, 1 MiB header JSON, version 1).
constexpr std::array<std::uint32_t, 18> kValues = {
    0,     1,        2,        207,     208,     209,        416,        65535,      65536,
    65537, 13631488, 13631696, 1048576, 1048577, 0x7fffffff, 0x80000000, 0xfffffffe, 0xffffffff};

void mutate_once(Bytes& b, const std::vector<Bytes>& corpus, Rng& r) {
  switch (r.below(8)) {
    case 0:  // bit flip
      if (!b.empty()) b[r.below(b.size())] ^= static_cast<std::uint8_t>(1u << r.below(8));
      break;
    case 1:  // random byte
      if (!b.empty()) b[r.below(b.size())] = static_cast<std::uint8_t>(r.next());
      break;
    case 2:  // truncate
      b.resize(r.below(b.size() + 1));
      break;
    case 3: {  // insert random bytes
      const std::size_t at = r.below(b.size() + 1), n = 1 + r.below(8);
      Bytes ins(n);
      for (auto& c : ins) c = static_cast<std::uint8_t>(r.next());
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), ins.begin(), ins.end());
      break;
    }
    case 4: {  // delete a span
      if (b.empty()) break;
      const std::size_t at = r.below(b.size()),
                        n = 1 + r.below(std::min<std::size_t>(64, b.size() - at));
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(at + n));
      break;
    }
    case 5: {  // duplicate a span, long enough to repeat a whole block
      if (b.empty()) break;
      const std::size_t at = r.below(b.size()),
                        n = 1 + r.below(std::min<std::size_t>(512, b.size() - at));
      const Bytes span(b.begin() + static_cast<std::ptrdiff_t>(at),
                       b.begin() + static_cast<std::ptrdiff_t>(at + n));
      const std::size_t to = r.below(b.size() + 1);
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(to), span.begin(), span.end());
      break;
    }
    case 6: {  // splice: our prefix, another file's suffix
      const Bytes& o = corpus[r.below(corpus.size())];
      const std::size_t keep = r.below(b.size() + 1), from = r.below(o.size() + 1);
      b.resize(keep);
      b.insert(b.end(), o.begin() + static_cast<std::ptrdiff_t>(from), o.end());
      break;
    }
    default: {  // a 32-bit field gets a limit value (4-aligned: fields are)
      if (b.size() < 4) break;
      const std::size_t at = r.below(b.size() / 4) * 4;
      const std::uint32_t v = kValues[r.below(kValues.size())];
      std::memcpy(b.data() + at, &v, 4);
      break;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  dentar::fuzz::ReplayHooks h;
  h.mutate = [](Bytes& b, const std::vector<Bytes>& corpus, Rng& r) { mutate_once(b, corpus, r); };
  h.run = [](const Bytes& b) { LLVMFuzzerTestOneInput(b.data(), b.size()); };
  return dentar::fuzz::replay_main(argc, argv, h);
}
