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

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

using Bytes = std::vector<std::uint8_t>;

// splitmix64: small and identical on every platform, so runs repeat exactly.
struct Rng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(next() % n); }
};

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
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <corpus dir> [--mutations N] [--seed S]\n", argv[0]);
    return 2;
  }
  long mutations = 0;
  std::uint64_t seed = 1;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string_view a = argv[i];
    if (a == "--mutations") {
      mutations = std::strtol(argv[i + 1], nullptr, 10);
    } else if (a == "--seed") {
      seed = std::strtoull(argv[i + 1], nullptr, 10);
    } else {
      std::fprintf(stderr, "unknown option %s\n", argv[i]);
      return 2;
    }
  }
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(argv[1], ec))
    if (e.is_regular_file()) files.push_back(e.path());
  if (ec || files.empty()) {
    std::fprintf(stderr, "%s: no corpus files (%s)\n", argv[1], ec.message().c_str());
    return 2;
  }
  std::sort(files.begin(), files.end());  // deterministic order
  std::vector<Bytes> corpus;
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    corpus.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& c : corpus) LLVMFuzzerTestOneInput(c.data(), c.size());
  Rng rng{seed};
  for (long m = 0; m < mutations; ++m) {
    Bytes b = corpus[static_cast<std::size_t>(m) % corpus.size()];
    const std::size_t rounds = 1 + rng.below(4);
    for (std::size_t k = 0; k < rounds; ++k) mutate_once(b, corpus, rng);
    LLVMFuzzerTestOneInput(b.data(), b.size());
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%zu corpus files + %ld mutations replayed in %.2f s\n", corpus.size(), mutations, s);
  return 0;
}
