// Replay driver for text-format fuzz targets without libFuzzer (used by calibration/fuzz and
// ar/fuzz): runs every file of a corpus directory, then N deterministic mutations of them. The
// mutations suit text formats (JSON, YAML, XML, CLI specs): bit flips, random printable bytes,
// truncation, deletion, duplicated spans (nesting, repeated keys), splices of two corpus files,
// tokens from a libFuzzer-format dictionary (the same file libFuzzer takes with -dict=) and
// numbers replaced by values on the limits (huge, tiny, negative, non-finite spellings).
// A crash, sanitizer report or trap is the failure signal; the exit code is 0 otherwise. On a
// crash signal the input being run is saved as ./replay-crash-input (like libFuzzer's crash-*
// files), so it can be run again alone: <target>_replay <dir holding only that file>.
//   usage: <target>_replay <corpus dir> [--mutations N] [--seed S] [--dict FILE]
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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

// Numbers on the parsers' limits: zero and signs, int overflow, double overflow/underflow,
// non-finite spellings of JSON/YAML/C, exponents.
constexpr std::array<const char*, 22> kNumbers = {
    "0",    "-0",     "1",       "-1",          "2147483647", "2147483648", "-2147483649",
    "1e308", "1e309", "-1e309",  "4.9e-324",    "1e-400",     "nan",        ".nan",
    "inf",  "-.inf",  "NaN",     "1e",          "0x10",       "99999999999999999999",
    "3",    "1.5"};

// libFuzzer dictionary lines: optional name, '=', then "token" with \\, \" and \xNN escapes.
std::vector<std::string> read_dict(const char* path) {
  std::vector<std::string> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto q0 = line.find('"'), q1 = line.rfind('"');
    if (line.empty() || line[0] == '#' || q0 == std::string::npos || q1 <= q0) continue;
    std::string t;
    for (std::size_t i = q0 + 1; i < q1; ++i) {
      if (line[i] != '\\' || i + 1 >= q1) {
        t += line[i];
      } else if (line[i + 1] == 'x' && i + 3 < q1) {
        t += static_cast<char>(std::strtol(line.substr(i + 2, 2).c_str(), nullptr, 16));
        i += 3;
      } else {
        t += line[++i];
      }
    }
    out.push_back(t);
  }
  return out;
}

// The input being run, for the crash handler (written before each run, read only there).
const std::uint8_t* g_current = nullptr;
std::size_t g_current_size = 0;

void save_and_reraise(int sig) {
  // Only async-signal-safe calls here.
  const int fd = ::open("replay-crash-input", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    std::size_t done = 0;
    while (done < g_current_size) {
      const ssize_t n = ::write(fd, g_current + done, g_current_size - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::close(fd);
  }
  static const char msg[] = "replay: crash; input saved as ./replay-crash-input\n";
  (void)!::write(2, msg, sizeof msg - 1);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void run(const Bytes& b) {
  g_current = b.data();
  g_current_size = b.size();
  LLVMFuzzerTestOneInput(b.data(), b.size());
}

void insert_text(Bytes& b, std::size_t at, std::string_view s) {
  b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), s.begin(), s.end());
}

void mutate_once(Bytes& b, const std::vector<Bytes>& corpus, const std::vector<std::string>& dict,
                 Rng& r) {
  switch (r.below(9)) {
    case 0:  // bit flip
      if (!b.empty()) b[r.below(b.size())] ^= static_cast<std::uint8_t>(1u << r.below(8));
      break;
    case 1:  // random printable byte (structure characters are the interesting ones)
      if (!b.empty()) b[r.below(b.size())] = static_cast<std::uint8_t>(0x20 + r.below(0x5f));
      break;
    case 2:  // truncate
      b.resize(r.below(b.size() + 1));
      break;
    case 3: {  // delete a span
      if (b.empty()) break;
      const std::size_t at = r.below(b.size()),
                        n = 1 + r.below(std::min<std::size_t>(64, b.size() - at));
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(at),
              b.begin() + static_cast<std::ptrdiff_t>(at + n));
      break;
    }
    case 4: {  // duplicate a span: repeated keys, array entries, nesting
      if (b.empty()) break;
      const std::size_t at = r.below(b.size()),
                        n = 1 + r.below(std::min<std::size_t>(512, b.size() - at));
      const Bytes span(b.begin() + static_cast<std::ptrdiff_t>(at),
                       b.begin() + static_cast<std::ptrdiff_t>(at + n));
      const std::size_t to = r.below(b.size() + 1);
      b.insert(b.begin() + static_cast<std::ptrdiff_t>(to), span.begin(), span.end());
      break;
    }
    case 5: {  // splice: our prefix, another file's suffix
      const Bytes& o = corpus[r.below(corpus.size())];
      const std::size_t keep = r.below(b.size() + 1), from = r.below(o.size() + 1);
      b.resize(keep);
      b.insert(b.end(), o.begin() + static_cast<std::ptrdiff_t>(from), o.end());
      break;
    }
    case 6:  // a dictionary token somewhere
      if (!dict.empty()) insert_text(b, r.below(b.size() + 1), dict[r.below(dict.size())]);
      break;
    default: {  // the number at a random place becomes a limit value
      if (b.empty()) break;
      std::size_t at = r.below(b.size());
      while (at < b.size() && !std::isdigit(b[at])) ++at;
      if (at == b.size()) break;
      std::size_t begin = at, end = at;
      while (begin > 0 && (std::isdigit(b[begin - 1]) || b[begin - 1] == '.' || b[begin - 1] == '-'))
        --begin;
      while (end < b.size() && (std::isdigit(b[end]) || b[end] == '.' || b[end] == 'e' ||
                                b[end] == 'E' || b[end] == '+' || b[end] == '-'))
        ++end;
      b.erase(b.begin() + static_cast<std::ptrdiff_t>(begin),
              b.begin() + static_cast<std::ptrdiff_t>(end));
      insert_text(b, begin, kNumbers[r.below(kNumbers.size())]);
      break;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> dict;
  dentar::fuzz::ReplayHooks h;
  h.extra_usage = " [--dict FILE]";
  h.option = [&dict](std::string_view name, const char* value) {
    if (name != "--dict") {
      std::fprintf(stderr, "unknown option %.*s\n", static_cast<int>(name.size()), name.data());
      return false;
    }
    dict = read_dict(value);
    if (dict.empty()) std::fprintf(stderr, "%s: no dictionary entries\n", value);
    return !dict.empty();
  };
  h.mutate = [&dict](Bytes& b, const std::vector<Bytes>& corpus, Rng& r) {
    mutate_once(b, corpus, dict, r);
  };
  // Crash signals save the input being run (installed before the first run).
  for (int sig : {SIGILL, SIGSEGV, SIGABRT, SIGFPE, SIGBUS}) std::signal(sig, save_and_reraise);
  h.run = [](const Bytes& b) { run(b); };
  return dentar::fuzz::replay_main(argc, argv, h);
}
