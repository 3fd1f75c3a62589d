// The part every fuzz replay driver (volume/, haptics/, calibration/ + ar/
// fuzz/) shares: the deterministic RNG, option parsing, loading the corpus in
// a fixed order, and the replay loop (every corpus file, then N mutated
// copies: copy = corpus[m % size], 1..4 rounds of the driver's own
// mutate(), run). Each driver keeps the mutations that suit its format.
// Header-only: the drivers are single-file executables built beside each
// fuzz target (no library to link).
//
// Every input runs under a time limit (--max-input-seconds, default 10 s, 0
// turns it off): an input that runs longer is a hang. The driver then prints
// which input (corpus file or mutation number and seed) hung, writes the
// bytes to ./replay-hang-input, and aborts, so the ctest fails instead of
// waiting for its suite-wide TIMEOUT.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/time.h>
#include <unistd.h>

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

namespace detail {
// The input being run and what to call it, for the SIGALRM handler (set before each run).
inline const std::uint8_t* g_hang_data = nullptr;
inline std::size_t g_hang_size = 0;
inline char g_hang_label[256] = {0};

inline void on_hang(int) {
  // Only async-signal-safe calls here.
  const int fd = ::open("replay-hang-input", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    std::size_t done = 0;
    while (done < g_hang_size) {
      const ssize_t n = ::write(fd, g_hang_data + done, g_hang_size - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::close(fd);
  }
  static const char head[] = "replay: HANG: input ";
  static const char tail[] =
      " ran past the per-input time limit; bytes saved as ./replay-hang-input\n";
  (void)!::write(2, head, sizeof head - 1);
  std::size_t n = 0;
  while (n < sizeof g_hang_label && g_hang_label[n]) ++n;
  (void)!::write(2, g_hang_label, n);
  (void)!::write(2, tail, sizeof tail - 1);
  ::signal(SIGABRT, SIG_DFL);  // not the crash handler: the input is already saved
  ::abort();
}

inline void arm(double seconds) {
  itimerval t{};
  t.it_value.tv_sec = static_cast<time_t>(seconds);
  t.it_value.tv_usec = static_cast<suseconds_t>((seconds - static_cast<double>(t.it_value.tv_sec)) * 1e6);
  ::setitimer(ITIMER_REAL, &t, nullptr);
}
inline void disarm() {
  itimerval t{};
  ::setitimer(ITIMER_REAL, &t, nullptr);
}
}  // namespace detail

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

// usage: <driver> <corpus dir> [--mutations N] [--seed S] [--max-input-seconds T]
//        <extra options>.
// Exit 0 after the replay; 2 on bad arguments or an empty corpus. A crash,
// sanitizer report or trap inside run() is the failure signal.
inline int replay_main(int argc, char** argv, const ReplayHooks& h) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <corpus dir> [--mutations N] [--seed S] [--max-input-seconds T]%s\n",
                 argv[0], h.extra_usage);
    return 2;
  }
  long mutations = 0;
  double max_input_s = 10;
  std::uint64_t seed = 1;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string_view a = argv[i];
    if (a == "--mutations") {
      mutations = std::strtol(argv[i + 1], nullptr, 10);
    } else if (a == "--seed") {
      seed = std::strtoull(argv[i + 1], nullptr, 10);
    } else if (a == "--max-input-seconds") {
      char* end = nullptr;
      max_input_s = std::strtod(argv[i + 1], &end);
      if (end == argv[i + 1] || *end != '\0' || !(max_input_s >= 0 && max_input_s <= 86400)) {
        std::fprintf(stderr, "--max-input-seconds %s: give seconds in 0..86400 (0: no limit)\n",
                     argv[i + 1]);
        return 2;
      }
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
  if (max_input_s > 0) ::signal(SIGALRM, detail::on_hang);
  // Runs one input under the time limit; label says which input it is.
  auto timed_run = [&](const Bytes& b) {
    detail::g_hang_data = b.data();
    detail::g_hang_size = b.size();
    if (max_input_s > 0) detail::arm(max_input_s);
    h.run(b);
    if (max_input_s > 0) detail::disarm();
  };
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < corpus.size(); ++i) {
    std::snprintf(detail::g_hang_label, sizeof detail::g_hang_label, "corpus file %s",
                  files[i].string().c_str());
    timed_run(corpus[i]);
  }
  Rng rng{seed};
  for (long m = 0; m < mutations; ++m) {
    Bytes b = corpus[static_cast<std::size_t>(m) % corpus.size()];
    const std::size_t rounds = 1 + rng.below(4);
    for (std::size_t k = 0; k < rounds; ++k) h.mutate(b, corpus, rng);
    std::snprintf(detail::g_hang_label, sizeof detail::g_hang_label,
                  "mutation %ld (--seed %llu)", m, static_cast<unsigned long long>(seed));
    timed_run(b);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%zu corpus files + %ld mutations replayed in %.2f s\n", corpus.size(), mutations, s);
  return 0;
}

}  // namespace dentar::fuzz
