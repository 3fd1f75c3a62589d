// The part every fuzz replay driver (volume/, haptics/, calibration/ + ar/
// fuzz/) shares: the deterministic RNG, option parsing, loading the corpus in
// a fixed order, and the replay loop (every corpus file, then N mutated
// copies: copy = corpus[m % size], 1..4 rounds of the driver's own
// mutate(), run). Each driver keeps the mutations that suit its format.
// Header-only: the drivers are single-file executables built beside each
// fuzz target (no library to link).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string_view>
#include <vector>

namespace dentar::fuzz {

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

struct ReplayHooks {
  // Extra "--name value" options ("" when none), e.g. " [--dict FILE]".
  const char* extra_usage = "";
  // Handles one extra option; returns false (after printing why) to stop
  // with exit code 2. Unset: every option other than --mutations/--seed is
  // unknown.
  std::function<bool(std::string_view name, const char* value)> option;
  // One round of mutation of b (the corpus is there for splices).
  std::function<void(Bytes& b, const std::vector<Bytes>& corpus, Rng& rng)> mutate;
  // Runs one input through the target.
  std::function<void(const Bytes& b)> run;
};

// usage: <driver> <corpus dir> [--mutations N] [--seed S] <extra options>.
// Exit 0 after the replay; 2 on bad arguments or an empty corpus. A crash,
// sanitizer report or trap inside run() is the failure signal.
inline int replay_main(int argc, char** argv, const ReplayHooks& h) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <corpus dir> [--mutations N] [--seed S]%s\n", argv[0],
                 h.extra_usage);
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
    } else if (h.option) {
      if (!h.option(a, argv[i + 1])) return 2;
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
  for (const auto& c : corpus) h.run(c);
  Rng rng{seed};
  for (long m = 0; m < mutations; ++m) {
    Bytes b = corpus[static_cast<std::size_t>(m) % corpus.size()];
    const std::size_t rounds = 1 + rng.below(4);
    for (std::size_t k = 0; k < rounds; ++k) h.mutate(b, corpus, rng);
    h.run(b);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%zu corpus files + %ld mutations replayed in %.2f s\n", corpus.size(), mutations, s);
  return 0;
}

}  // namespace dentar::fuzz
