// Fuzz target: parse_session_log on arbitrary bytes.
//
// Random bytes almost never pass the CRCs, which would hide the count and
// length checks behind them. So every input is parsed twice: as is, and with
// each CRC the input claims to have recomputed ("sealed"), which lets the
// fuzzer reach every structural check with valid checksums.
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "dentar/haptics/session_log.h"

namespace {

using dentar::haptics::kLogBlockHeaderBytes;
using dentar::haptics::kLogCrcBytes;
using dentar::haptics::kLogFileHeaderFixedBytes;
using dentar::haptics::kStepRecordBytes;

std::uint32_t load_u32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

void store_crc(std::uint8_t* begin, std::size_t covered) {
  const auto crc = static_cast<std::uint32_t>(::crc32(0, begin, static_cast<uInt>(covered)));
  std::memcpy(begin + covered, &crc, 4);
}

// Rewrites the header CRC and every block CRC the declared lengths locate,
// stopping where the lengths run past the end.
void seal(std::vector<std::uint8_t>& b) {
  if (b.size() < kLogFileHeaderFixedBytes) return;
  const std::uint64_t json = load_u32(b.data() + 16);
  std::uint64_t off = kLogFileHeaderFixedBytes + json;
  if (off + kLogCrcBytes > b.size()) return;
  store_crc(b.data(), static_cast<std::size_t>(off));
  off += kLogCrcBytes;
  while (off + kLogBlockHeaderBytes <= b.size()) {
    const std::uint64_t payload = load_u32(b.data() + off + 8);
    const std::uint64_t covered = kLogBlockHeaderBytes + payload;
    if (off + covered + kLogCrcBytes > b.size()) return;
    store_crc(b.data() + off, static_cast<std::size_t>(covered));
    off += covered + kLogCrcBytes;
  }
}

// Contracts every successful parse must keep, whatever the input.
void check(const dentar::Result<dentar::haptics::SessionLog>& r, std::size_t size) {
  if (!r) {
    if (r.error().rfind("fuzz.dlog: ", 0) != 0) __builtin_trap();  // errors name the file
    return;
  }
  const auto& log = *r;
  if (log.good_bytes > size) __builtin_trap();
  if (log.records.size() * kStepRecordBytes > log.good_bytes) __builtin_trap();
  if (log.good_blocks > log.records.size()) __builtin_trap();          // blocks hold >= 1 record
  if (log.good_bytes < size && log.warning.empty()) __builtin_trap();  // damage is never silent
  if (log.good_bytes == size && !log.warning.empty()) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The sealed copy of a huge input would only slow the fuzzer down.
  if (size > (1u << 20)) return 0;
  check(dentar::haptics::parse_session_log(data, size, "fuzz.dlog"), size);
  std::vector<std::uint8_t> sealed(data, data + size);
  seal(sealed);
  check(dentar::haptics::parse_session_log(sealed.data(), sealed.size(), "fuzz.dlog"), size);
  return 0;
}
