// Replay driver for the fuzz targets without libFuzzer: runs every file of a
// corpus directory, then N deterministic mutations of them (bit flips, byte
// overwrites, truncations, insertions, deletions, duplicated spans and
// "interesting number" substitutions). A crash, sanitizer report or hang is the
// failure signal; the exit code is 0 otherwise.
//   usage: <target>_replay <corpus dir> [--mutations N] [--seed S]
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_replay.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

using dentar::fuzz::Bytes;
using dentar::fuzz::Rng;

// Numbers that sit on the limits the parsers check.
constexpr std::array<std::string_view, 18> kNumbers = {
    "0",    "-1",  "1",           "4096",   "4097",  "2147483648",           "-0",
    "nan",  "inf", "1e308",       "1e-320", "65536", "99999999999999999999", "3.5",
    "0x10", "2",   "-2147483649", "1290"};

void mutate_once(Bytes& b, Rng& r) {
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
                        n = 1 + r.below(std::min<std::size_t>(16, b.size() - at));
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(at + n));
      break;
    }
    case 5: {  // duplicate a span
      if (b.empty()) break;
      const std::size_t at = r.below(b.size()),
                        n = 1 + r.below(std::min<std::size_t>(32, b.size() - at));
      const Bytes span(b.begin() + static_cast<std::ptrdiff_t>(at),
                       b.begin() + static_cast<std::ptrdiff_t>(at + n));
      const std::size_t to = r.below(b.size() + 1);
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(to), span.begin(), span.end());
      break;
    }
    default: {  // replace a run of digits with an interesting number
      std::vector<std::size_t> starts;
      for (std::size_t i = 0; i < b.size(); ++i)
        if (b[i] >= '0' && b[i] <= '9' && (i == 0 || b[i - 1] < '0' || b[i - 1] > '9'))
          starts.push_back(i);
      if (starts.empty()) break;
      const std::size_t at = starts[r.below(starts.size())];
      std::size_t end = at;
      while (end < b.size() && ((b[end] >= '0' && b[end] <= '9') || b[end] == '.')) ++end;
      const std::string_view num = kNumbers[r.below(kNumbers.size())];
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(end));
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), num.begin(), num.end());
      break;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  dentar::fuzz::ReplayHooks h;
  h.mutate = [](Bytes& b, const std::vector<Bytes>&, Rng& r) { mutate_once(b, r); };
  h.run = [](const Bytes& b) { LLVMFuzzerTestOneInput(b.data(), b.size()); };
  return dentar::fuzz::replay_main(argc, argv, h);
}
