#include "dentar/haptics/session_log.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "testutil.h"

namespace dentar::haptics {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// A record whose every byte depends on i, with the awkward doubles a
// reader must not normalise (-0, NaN payloads, infinities, denormals).
StepRecord make_record(std::uint64_t i) {
  StepRecord r;
  const double x = static_cast<double>(i);
  r.step = i;
  r.time_s = 1e-3 * x;
  for (int k = 0; k < 3; ++k) r.position_m[k] = 0.01 * std::sin(x + k);
  for (int k = 0; k < 9; ++k) r.rotation[k] = std::cos(9 * x + k);
  for (int k = 0; k < 3; ++k) r.velocity_m_per_s[k] = 0.1 * std::sin(3 * x + k);
  for (int k = 0; k < 3; ++k) r.force_dev_N[k] = 2.0 * std::cos(5 * x + k);
  if (i % 7 == 0) r.force_dev_N[0] = -0.0;
  if (i % 11 == 3) r.force_dev_N[1] = std::bit_cast<double>(0x7ff8000000000123ull + i);
  if (i % 13 == 5) r.velocity_m_per_s[2] = -std::numeric_limits<double>::infinity();
  if (i % 17 == 6) r.position_m[1] = std::numeric_limits<double>::denorm_min();
  r.buttons = static_cast<std::uint32_t>(i * 2654435761u);
  r.contacts = static_cast<std::uint32_t>(i % 1000);
  for (int k = 0; k < 8; ++k) r.removed[k] = static_cast<std::uint32_t>(i ^ (k * 0x01010101u));
  r.pedal = static_cast<std::uint8_t>(i & 1);
  r.bur_id = static_cast<std::uint8_t>(i % 5);
  r.flags = static_cast<std::uint8_t>(i & 0x1f);
  for (int k = 0; k < 5; ++k) r.reserved[k] = static_cast<std::uint8_t>(i + k);
  return r;
}

bool same_bits(const StepRecord& a, const StepRecord& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;  // no padding: every byte is a field
}

std::string contains_msg(const std::string& haystack, const std::string& needle) {
  return "\"" + haystack + "\" should contain \"" + needle + "\"";
}
#define EXPECT_CONTAINS(hay, needle) \
  EXPECT_NE((hay).find(needle), std::string::npos) << contains_msg((hay), (needle))

Result<SessionLog> parse_bytes(const std::string& bytes, std::size_t len, const std::string& name) {
  return parse_session_log(reinterpret_cast<const std::uint8_t*>(bytes.data()), len, name);
}

// A small hand-built log: header + blocks of the given sizes.
struct SmallLog {
  std::string bytes;
  std::size_t header_end = 0;
  std::vector<std::size_t> block_begin, block_end, records_before;  // per block
  std::vector<StepRecord> records;
};

SmallLog small_log(const std::vector<std::size_t>& sizes) {
  SmallLog s;
  s.bytes = encode_session_log_header(R"({"kind":"molar"})");
  s.header_end = s.bytes.size();
  for (std::size_t n : sizes) {
    std::vector<StepRecord> rs;
    for (std::size_t k = 0; k < n; ++k) rs.push_back(make_record(s.records.size() + k));
    s.block_begin.push_back(s.bytes.size());
    s.records_before.push_back(s.records.size());
    s.bytes += encode_session_log_block(rs, s.records.size(), 0);
    s.block_end.push_back(s.bytes.size());
    s.records.insert(s.records.end(), rs.begin(), rs.end());
  }
  return s;
}

LogWriterOptions fast_options(std::size_t capacity = 1 << 14) {
  LogWriterOptions o;
  o.ring_capacity = capacity;
  o.flush_interval_s = 0.01;
  o.fsync = false;  // tmpfs or not, the tests check content, not durability
  return o;
}

// ---------------------------------------------------------------- writer + reader

TEST(SessionLog, RoundTripOfManyRecordsIsBitExact) {
  const auto path = (test::temp_dir("log") / "session.dlog").string();
  const std::string json = R"({"engine":{"rate_hz":1000},"bur":"round_1.0"})";
  constexpr std::uint64_t kN = 5000;
  LogWriterOptions opt;
  opt.ring_capacity = 8192;  // holds everything: no drops whatever the scheduling
  opt.flush_interval_s = 0.02;
  opt.fsync = true;
  auto w = SessionLogWriter::open(path, json, opt);
  ASSERT_TRUE(w.ok()) << w.error();
  for (std::uint64_t i = 0; i < kN; ++i) ASSERT_TRUE((*w)->push(make_record(i)));
  const Status st = (*w)->close();
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_EQ((*w)->written(), kN);
  EXPECT_EQ((*w)->dropped(), 0u);

  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->version, kSessionLogVersion);
  EXPECT_EQ(log->header_json, json);
  EXPECT_EQ(log->warning, "");
  EXPECT_EQ(log->dropped, 0u);
  EXPECT_GE(log->good_blocks, 2u);  // kN > the writer's 4096-record block
  EXPECT_EQ(log->good_bytes, test::read_file(path).size());
  ASSERT_EQ(log->records.size(), kN);
  for (std::uint64_t i = 0; i < kN; ++i)
    ASSERT_TRUE(same_bits(log->records[i], make_record(i))) << "record " << i;

  // The in-memory parser sees the same.
  const std::string bytes = test::read_file(path);
  auto mem = parse_bytes(bytes, bytes.size(), "mem");
  ASSERT_TRUE(mem.ok()) << mem.error();
  ASSERT_EQ(mem->records.size(), kN);
  EXPECT_EQ(std::memcmp(mem->records.data(), log->records.data(), kN * sizeof(StepRecord)), 0);
}

TEST(SessionLog, HeaderJsonIsPreservedByteForByte) {
  const auto dir = test::temp_dir("log");
  std::string big(200000, 'x');
  for (std::size_t i = 0; i < big.size(); i += 97) big[i] = static_cast<char>('a' + i % 26);
  const char kWeird[] = "{\"name\":\"d\xc3\xa9nt\\n\",\n\"nul\":\"a\0b\"}";  // UTF-8, NUL
  const std::vector<std::string> jsons = {"", "{}", std::string(kWeird, sizeof kWeird - 1), big};
  for (std::size_t k = 0; k < jsons.size(); ++k) {
    const auto path = (dir / (std::to_string(k) + ".dlog")).string();
    auto w = SessionLogWriter::open(path, jsons[k], fast_options());
    ASSERT_TRUE(w.ok()) << w.error();
    ASSERT_TRUE((*w)->push(make_record(k)));
    ASSERT_TRUE((*w)->close().ok());
    auto log = read_session_log(path);
    ASSERT_TRUE(log.ok()) << log.error();
    EXPECT_EQ(log->header_json, jsons[k]) << "json " << k;
    EXPECT_EQ(log->records.size(), 1u);
    EXPECT_EQ(log->warning, "");
  }
  const auto path = (dir / "too_big.dlog").string();
  auto w = SessionLogWriter::open(path, std::string(kMaxHeaderJsonBytes + 1, ' '));
  ASSERT_FALSE(w.ok());
  EXPECT_CONTAINS(w.error(), path);
  EXPECT_CONTAINS(w.error(), "limit");
}

TEST(SessionLog, EmptyLogHasHeaderOnly) {
  const auto path = (test::temp_dir("log") / "empty.dlog").string();
  {
    auto w = SessionLogWriter::open(path, "{}", fast_options());
    ASSERT_TRUE(w.ok()) << w.error();
  }  // destructor closes
  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_TRUE(log->records.empty());
  EXPECT_EQ(log->good_blocks, 0u);
  EXPECT_EQ(log->warning, "");
}

TEST(SessionLog, DestructorWritesEverythingPushed) {
  const auto path = (test::temp_dir("log") / "dtor.dlog").string();
  {
    auto w = SessionLogWriter::open(path, "{}", fast_options());
    ASSERT_TRUE(w.ok()) << w.error();
    for (std::uint64_t i = 0; i < 10; ++i) ASSERT_TRUE((*w)->push(make_record(i)));
  }
  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  ASSERT_EQ(log->records.size(), 10u);
  EXPECT_TRUE(same_bits(log->records[9], make_record(9)));
}

TEST(SessionLog, CloseIsIdempotentAndPushAfterCloseIsCountedAsDropped) {
  const auto path = (test::temp_dir("log") / "closed.dlog").string();
  auto w = SessionLogWriter::open(path, "{}", fast_options());
  ASSERT_TRUE(w.ok()) << w.error();
  ASSERT_TRUE((*w)->push(make_record(0)));
  EXPECT_TRUE((*w)->close().ok());
  EXPECT_TRUE((*w)->close().ok());
  EXPECT_FALSE((*w)->push(make_record(1)));
  EXPECT_EQ((*w)->dropped(), 1u);
  EXPECT_EQ((*w)->written(), 1u);
}

TEST(SessionLog, BlocksAreWrittenWhileRunningNotOnlyAtClose) {
  const auto path = (test::temp_dir("log") / "live.dlog").string();
  auto w = SessionLogWriter::open(path, "{}", fast_options());
  ASSERT_TRUE(w.ok()) << w.error();
  for (std::uint64_t i = 0; i < 100; ++i) ASSERT_TRUE((*w)->push(make_record(i)));
  const auto t0 = Clock::now();
  while ((*w)->written() < 100 && Clock::now() - t0 < 10s) std::this_thread::sleep_for(1ms);
  ASSERT_EQ((*w)->written(), 100u) << "the logger thread never flushed before close()";
  auto log = read_session_log(path);  // the writer is still open
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->records.size(), 100u);
  EXPECT_EQ(log->warning, "");
  EXPECT_TRUE((*w)->close().ok());
}

TEST(SessionLog, RingOverflowCountsDropsWithoutBlocking) {
  const auto path = (test::temp_dir("log") / "overflow.dlog").string();
  LogWriterOptions opt = fast_options(8);
  opt.flush_interval_s = 0.1;
  auto w = SessionLogWriter::open(path, "{}", opt);
  ASSERT_TRUE(w.ok()) << w.error();
  constexpr std::uint64_t kN = 100000;
  std::uint64_t refused = 0;
  const StepRecord base = make_record(1);
  const auto t0 = Clock::now();
  for (std::uint64_t i = 0; i < kN; ++i) {
    StepRecord r = base;
    r.step = i;
    if (!(*w)->push(r)) ++refused;
  }
  const double push_s = std::chrono::duration<double>(Clock::now() - t0).count();
  // 100k pushes take about a millisecond; blocking on a logger that wakes
  // every few milliseconds would take seconds.
  EXPECT_LT(push_s, 2.0);
  EXPECT_GT(refused, 0u);
  EXPECT_EQ((*w)->dropped(), refused);
  ASSERT_TRUE((*w)->close().ok());
  EXPECT_EQ((*w)->written() + (*w)->dropped(), kN);

  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->warning, "");
  ASSERT_EQ(log->records.size(), (*w)->written());
  EXPECT_LE(log->dropped, refused);  // as of the last block
  for (std::size_t i = 1; i < log->records.size(); ++i)
    ASSERT_LT(log->records[i - 1].step, log->records[i].step) << "order broken at " << i;
}

TEST(SessionLog, ConcurrentProducerRecordsAllArriveInOrder) {
  const auto path = (test::temp_dir("log") / "concurrent.dlog").string();
  auto w = SessionLogWriter::open(path, R"({"test":"concurrent"})", fast_options(4096));
  ASSERT_TRUE(w.ok()) << w.error();
  SessionLogWriter* writer = w->get();
  constexpr std::uint64_t kN = 200000;
  std::atomic<bool> done{false};
  std::uint64_t refused = 0;  // producer only; read after join
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kN; ++i) {
      StepRecord r;
      r.step = i;
      r.time_s = 1e-3 * static_cast<double>(i);
      r.removed[7] = static_cast<std::uint32_t>(~i);
      // A test may retry; the haptic thread would drop and move on.
      while (!writer->push(r)) {
        ++refused;
        std::this_thread::yield();
      }
    }
    done.store(true, std::memory_order_release);
  });
  // Meanwhile, read the growing file: always a clean prefix (perhaps with a
  // block still being written at its end).
  bool read_midway = false;
  while (!done.load(std::memory_order_acquire)) {
    if (!read_midway && writer->written() > kN / 4) {
      auto partial = read_session_log(path);
      ASSERT_TRUE(partial.ok()) << partial.error();
      for (std::size_t i = 0; i < partial->records.size(); ++i)
        ASSERT_EQ(partial->records[i].step, i);
      read_midway = true;
    }
    std::this_thread::sleep_for(1ms);
  }
  producer.join();
  const Status st = writer->close();
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_EQ(writer->written(), kN);
  EXPECT_EQ(writer->dropped(), refused);

  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->warning, "");
  EXPECT_GT(log->good_blocks, 1u);
  ASSERT_EQ(log->records.size(), kN);
  for (std::uint64_t i = 0; i < kN; ++i) {
    ASSERT_EQ(log->records[i].step, i);
    ASSERT_EQ(log->records[i].removed[7], static_cast<std::uint32_t>(~i));
  }
}

// ---------------------------------------------------------------- damaged files

TEST(SessionLog, TruncationAtEveryByteOffsetKeepsWholeGoodBlocks) {
  const SmallLog s = small_log({3, 1, 5});
  const auto path = (test::temp_dir("log") / "cut.dlog").string();
  for (std::size_t len = 0; len <= s.bytes.size(); ++len) {
    SCOPED_TRACE("length " + std::to_string(len));
    auto log = parse_bytes(s.bytes, len, "cut.dlog");
    // The file reader shares the parser; check it on a sample of lengths
    // (every length would cost seconds of file system calls).
    const bool via_file = len % 16 == 0 || len == s.bytes.size() ||
                          std::any_of(s.block_end.begin(), s.block_end.end(),
                                      [&](std::size_t e) { return len + 1 >= e && len <= e + 1; });
    std::optional<Result<SessionLog>> from_file;
    if (via_file) {
      test::write_file(path, s.bytes.substr(0, len));
      from_file.emplace(read_session_log(path));
    }
    if (len < s.header_end) {
      ASSERT_FALSE(log.ok());
      EXPECT_CONTAINS(log.error(), "cut.dlog: ");
      if (from_file) {
        ASSERT_FALSE(from_file->ok());
        EXPECT_CONTAINS(from_file->error(), path);
      }
      continue;
    }
    ASSERT_TRUE(log.ok()) << log.error();
    std::size_t blocks = 0;
    while (blocks < s.block_end.size() && s.block_end[blocks] <= len) ++blocks;
    const std::size_t good_end = blocks == 0 ? s.header_end : s.block_end[blocks - 1];
    const std::size_t n = blocks < s.block_end.size() ? s.records_before[blocks] : s.records.size();
    EXPECT_EQ(log->good_blocks, blocks);
    EXPECT_EQ(log->good_bytes, good_end);
    ASSERT_EQ(log->records.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_TRUE(same_bits(log->records[i], s.records[i]));
    if (len == good_end) {
      EXPECT_EQ(log->warning, "");
    } else {
      EXPECT_CONTAINS(log->warning, "cut.dlog: byte offset " + std::to_string(good_end) + ": ");
      EXPECT_CONTAINS(log->warning, "truncated");
    }
    if (from_file) {
      ASSERT_TRUE(from_file->ok()) << from_file->error();
      const SessionLog& f = **from_file;
      EXPECT_EQ(f.records.size(), n);
      EXPECT_EQ(f.warning.empty(), log->warning.empty());
      if (!f.warning.empty()) {
        EXPECT_CONTAINS(f.warning, path);
      }
    }
  }
}

TEST(SessionLog, CorruptByteInABlockStopsAtThePreviousBlock) {
  const SmallLog s = small_log({3, 1, 5, 2});
  for (std::size_t b = 0; b < s.block_begin.size(); ++b) {
    for (std::size_t p = s.block_begin[b]; p < s.block_end[b]; ++p) {
      SCOPED_TRACE("block " + std::to_string(b) + ", byte " + std::to_string(p));
      std::string bad = s.bytes;
      bad[p] = static_cast<char>(bad[p] ^ 0x41);
      auto log = parse_bytes(bad, bad.size(), "bad.dlog");
      ASSERT_TRUE(log.ok()) << log.error();
      EXPECT_EQ(log->good_blocks, b);
      ASSERT_EQ(log->records.size(), s.records_before[b]);
      EXPECT_EQ(log->good_bytes, s.block_begin[b]);
      EXPECT_CONTAINS(log->warning,
                      "bad.dlog: byte offset " + std::to_string(s.block_begin[b]) + ": ");
    }
  }
}

TEST(SessionLog, CorruptByteInTheHeaderIsAnErrorNamingTheFile) {
  const SmallLog s = small_log({2});
  for (std::size_t p = 0; p < s.header_end; ++p) {
    std::string bad = s.bytes;
    bad[p] = static_cast<char>(bad[p] ^ 0x41);
    auto log = parse_bytes(bad, bad.size(), "hdr.dlog");
    ASSERT_FALSE(log.ok()) << "byte " << p;
    EXPECT_CONTAINS(log.error(), "hdr.dlog: ");
  }
}

TEST(SessionLog, BadFileHeadersAreErrorsNamingTheFileAndReason) {
  const std::string good = encode_session_log_header("{}");
  auto err = [](const std::string& bytes) {
    auto r = parse_bytes(bytes, bytes.size(), "x.dlog");
    return r.ok() ? std::string("(parsed)") : r.error();
  };
  EXPECT_CONTAINS(err(""), "x.dlog: not a DentAR session log");
  EXPECT_CONTAINS(err("P6\n640 480\n255\n...................."),
                  "x.dlog: not a DentAR session log");
  EXPECT_CONTAINS(err(good.substr(0, 12)), "x.dlog: truncated session log header");
  EXPECT_CONTAINS(err(good.substr(0, good.size() - 1)), "x.dlog: truncated session log header");

  std::string v2 = good;
  v2[8] = 2;
  EXPECT_CONTAINS(err(v2), "x.dlog: session log version 2 unsupported");
  std::string v0 = good;
  v0[8] = 0;
  EXPECT_CONTAINS(err(v0), "version 0 unsupported");

  std::string rec = good;
  rec[12] = static_cast<char>(200);
  EXPECT_CONTAINS(err(rec), "record size 200 unsupported");

  std::string crc = good;
  crc[20] = '[';  // "{}" -> "[}"
  EXPECT_CONTAINS(err(crc), "x.dlog: byte offset 22: header CRC mismatch");

  std::string huge = good;  // absurd JSON length: refused before allocating
  huge[16] = huge[17] = huge[18] = huge[19] = static_cast<char>(0xff);
  EXPECT_CONTAINS(err(huge), "header JSON length 4294967295 exceeds the limit");

  EXPECT_CONTAINS(err(good), "(parsed)");

  const std::string missing = (test::temp_dir("log") / "no_such.dlog").string();
  auto r = read_session_log(missing);
  ASSERT_FALSE(r.ok());
  EXPECT_CONTAINS(r.error(), missing);
  const std::string dir = test::temp_dir("log").string();
  r = read_session_log(dir);
  ASSERT_FALSE(r.ok());
  EXPECT_CONTAINS(r.error(), dir);
  EXPECT_FALSE(parse_session_log(nullptr, 0, "null").ok());
}

// Builds a block header with arbitrary (possibly absurd) fields and a CRC
// that matches them, so only the count checks can refuse it.
std::string raw_block(std::uint32_t count, std::uint32_t payload_bytes, std::uint64_t first,
                      const std::string& payload) {
  std::string b(kLogBlockHeaderBytes, '\0');
  std::memcpy(b.data(), "SLBK", 4);
  std::memcpy(b.data() + 4, &count, 4);
  std::memcpy(b.data() + 8, &payload_bytes, 4);
  std::memcpy(b.data() + 16, &first, 8);
  return b + payload + std::string(4, '\0');
}

TEST(SessionLog, AbsurdBlockCountsAreRefusedBeforeAllocating) {
  const SmallLog s = small_log({2});
  const std::string at = "byte offset " + std::to_string(s.bytes.size()) + ": ";
  auto warning = [&](const std::string& block) {
    const std::string bytes = s.bytes + block;
    auto r = parse_bytes(bytes, bytes.size(), "abs.dlog");
    EXPECT_TRUE(r.ok());
    if (!r.ok()) return std::string();
    EXPECT_EQ(r->records.size(), 2u);
    return r->warning;
  };
  EXPECT_CONTAINS(warning(raw_block(0xffffffffu, 0xffffffffu, 2, "")), at + "bad record count");
  EXPECT_CONTAINS(warning(raw_block(0, 0, 2, "")), at + "bad record count 0");
  EXPECT_CONTAINS(warning(raw_block(65537, 65537u * 208u, 2, "")), "bad record count 65537");
  EXPECT_CONTAINS(warning(raw_block(2, 208, 2, std::string(208, 'a'))),
                  "bad payload byte count 208 for 2 records");
  EXPECT_CONTAINS(warning(raw_block(65536, 65536u * 208u, 2, "")), at + "truncated block");
  EXPECT_CONTAINS(warning("XXXX" + raw_block(1, 208, 2, std::string(208, 'a')).substr(4)),
                  at + "bad block magic");
  EXPECT_CONTAINS(warning(std::string(10, '\0')), at + "truncated block header (10 of 32 bytes)");
}

TEST(SessionLog, MissingOrRepeatedBlocksAreDetected) {
  const StepRecord r0 = make_record(0), r1 = make_record(1);
  const std::string head = encode_session_log_header("{}");
  const std::string b0 = encode_session_log_block(std::span(&r0, 1), 0, 0);
  const std::string b1 = encode_session_log_block(std::span(&r1, 1), 1, 0);
  for (const std::string& bytes : {head + b0 + b0, head + b1, head + b0 + b1 + b1}) {
    auto r = parse_bytes(bytes, bytes.size(), "seq.dlog");
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_CONTAINS(r->warning, "missing or repeated block");
  }
  const std::string ok = head + b0 + b1;
  auto r = parse_bytes(ok, ok.size(), "seq.dlog");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->records.size(), 2u);
  EXPECT_EQ(r->warning, "");
}

TEST(SessionLog, DroppedCountIsRecordedPerBlock) {
  const StepRecord r0 = make_record(0);
  const std::string bytes = encode_session_log_header("{}") +
                            encode_session_log_block(std::span(&r0, 1), 0, 12) +
                            encode_session_log_block(std::span(&r0, 1), 1, 40);
  auto r = parse_bytes(bytes, bytes.size(), "d.dlog");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->dropped, 40u);
}

// ---------------------------------------------------------------- writer errors

TEST(SessionLog, UnwritablePathErrorNamesThePath) {
  const std::string path = (test::temp_dir("log") / "no_such_dir" / "s.dlog").string();
  auto w = SessionLogWriter::open(path, "{}");
  ASSERT_FALSE(w.ok());
  EXPECT_CONTAINS(w.error(), path);
  EXPECT_CONTAINS(w.error(), "cannot create session log");

  const std::string dir = test::temp_dir("log").string();
  w = SessionLogWriter::open(dir, "{}");
  ASSERT_FALSE(w.ok());
  EXPECT_CONTAINS(w.error(), dir);

  // A device that accepts the open but no data: the header write fails.
  if (::access("/dev/full", W_OK) == 0) {
    w = SessionLogWriter::open("/dev/full", "{}");
    ASSERT_FALSE(w.ok());
    EXPECT_CONTAINS(w.error(), "/dev/full: cannot write session log header");
  }
}

TEST(SessionLog, InvalidOptionsAreRejectedNamingTheField) {
  const std::string path = (test::temp_dir("log") / "o.dlog").string();
  LogWriterOptions o;
  EXPECT_EQ(o.validate(), "");
  o.ring_capacity = 1000;
  EXPECT_CONTAINS(o.validate(), "ring_capacity = 1000 must be a power of two");
  auto w = SessionLogWriter::open(path, "{}", o);
  ASSERT_FALSE(w.ok());
  EXPECT_CONTAINS(w.error(), path);
  EXPECT_CONTAINS(w.error(), "ring_capacity");
  o = {};
  o.flush_interval_s = 0.5;
  EXPECT_CONTAINS(o.validate(), "flush_interval_s = 0.5 s must be in (0, 0.1]");
  o.flush_interval_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_CONTAINS(o.validate(), "flush_interval_s");
  o.flush_interval_s = 0;
  EXPECT_CONTAINS(o.validate(), "flush_interval_s");
}

TEST(SessionLog, FixedSizeBlocksGiveTheSameBytesWhateverTheTiming) {
  // Two writers get the same 2500 records, one in bursts with pauses (the
  // logger wakes up in between), one all at once: with block_records the
  // files are byte-identical, blocks of 1000, 1000 and 500 records.
  const auto dir = test::temp_dir("log");
  LogWriterOptions o = fast_options(1 << 12);
  o.block_records = 1000;
  ASSERT_EQ(o.validate(), "");
  auto a = SessionLogWriter::open((dir / "a.dlog").string(), "{}", o);
  auto b = SessionLogWriter::open((dir / "b.dlog").string(), "{}", o);
  ASSERT_TRUE(a.ok() && b.ok());
  for (std::uint64_t i = 0; i < 2500; ++i) {
    ASSERT_TRUE((*a)->push(make_record(i)));
    if (i % 137 == 0) std::this_thread::sleep_for(2ms);
  }
  for (std::uint64_t i = 0; i < 2500; ++i) ASSERT_TRUE((*b)->push(make_record(i)));
  ASSERT_TRUE((*a)->close().ok());
  ASSERT_TRUE((*b)->close().ok());
  const std::string fa = test::read_file(dir / "a.dlog"), fb = test::read_file(dir / "b.dlog");
  auto log = read_session_log((dir / "a.dlog").string());
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_EQ(log->records.size(), 2500u);
  EXPECT_EQ(log->good_blocks, 3u);
  EXPECT_EQ(fa.size(), encode_session_log_header("{}").size() + 3 * (kLogBlockHeaderBytes + kLogCrcBytes) +
                           2500 * kStepRecordBytes);
  EXPECT_TRUE(fa == fb) << "same records, different bytes";

  o.block_records = 4097;
  EXPECT_CONTAINS(o.validate(), "block_records = 4097");
  o = fast_options(1 << 8);
  o.block_records = 200;
  EXPECT_CONTAINS(o.validate(), "block_records = 200 must be 0 (cut by time) or at most 128");
}

// Runs `child` in a forked process (single-threaded at fork: this test
// binary has no other threads between tests) and returns its wait status.
template <typename F>
int in_child(F&& child) {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(child());
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

TEST(SessionLog, WriteFailureIsReportedByCloseNamingTheFile) {
  const std::string path = (test::temp_dir("log") / "efbig.dlog").string();
  // In a child, cap the file size so a block write fails with EFBIG.
  const int status = in_child([&] {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit lim{4096, 4096};
    if (::setrlimit(RLIMIT_FSIZE, &lim) != 0) return 10;
    auto w = SessionLogWriter::open(path, "{}", fast_options());
    if (!w.ok()) return 11;
    for (std::uint64_t i = 0; i < 100; ++i) (*w)->push(make_record(i));  // 20 KB
    const Status st = (*w)->close();
    if (st.ok()) return 12;
    if (st.error().find(path + ": session log write failed at byte offset") != 0) return 13;
    if (st.error().find("records were not written") == std::string::npos) return 14;
    return 0;
  });
  ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10 setrlimit, 11 open, 12 close ok, 13/14 message";
  // Whatever reached the disk reads back up to the last whole block.
  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  EXPECT_LT(log->records.size(), 100u);
}

// Counters the crashing child publishes to the parent (shared anonymous map).
struct CrashShared {
  std::atomic<std::uint64_t> pushed{0};
  std::atomic<std::uint64_t> written{0};
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

TEST(SessionLog, CrashLosesAtMostTheLastFlushInterval) {
  const std::string path = (test::temp_dir("log") / "crash.dlog").string();
  void* mem = ::mmap(nullptr, sizeof(CrashShared), PROT_READ | PROT_WRITE,
                     MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mem, MAP_FAILED);
  auto* sh = new (mem) CrashShared;

  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    // Child: the haptic loop at ~1 kHz until SIGKILL (gives up after 60 s).
    LogWriterOptions opt;
    opt.flush_interval_s = 0.05;
    opt.fsync = false;  // SIGKILL, not power loss: the page cache survives
    auto w = SessionLogWriter::open(path, R"({"test":"crash"})", opt);
    if (!w.ok()) ::_exit(3);
    auto next = Clock::now();
    for (std::uint64_t i = 0; i < 60000; ++i) {
      (*w)->push(make_record(i));
      sh->pushed.store(i + 1, std::memory_order_release);
      sh->written.store((*w)->written(), std::memory_order_release);
      next += 1ms;
      std::this_thread::sleep_until(next);
    }
    ::_exit(4);
  }

  auto wait_for = [&](auto pred, std::chrono::seconds limit) {
    const auto t0 = Clock::now();
    while (!pred() && Clock::now() - t0 < limit) std::this_thread::sleep_for(1ms);
    return pred();
  };
  auto kill_child = [&] {
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return status;
  };
  if (!wait_for([&] { return sh->pushed.load() >= 300; }, 30s)) {
    kill_child();
    FAIL() << "the child did not start logging";
  }
  // Blocks reach the file while the child runs: without periodic flushing
  // (only at close) this times out.
  const std::uint64_t p1 = sh->pushed.load();
  const auto t1 = Clock::now();
  const bool flushed = wait_for([&] { return sh->written.load() >= p1; }, 10s);
  const double flush_wait_s = std::chrono::duration<double>(Clock::now() - t1).count();
  if (!flushed) {
    kill_child();
    FAIL() << "no block written within 10 s of pushing record " << p1;
  }
  // Kill at a moment unrelated to the flush phase, remembering what had been
  // pushed 0.2 s (4 flush intervals, slack for a loaded machine) before.
  std::this_thread::sleep_for(200ms);
  const std::uint64_t p_before = sh->pushed.load();
  std::this_thread::sleep_for(200ms);
  const std::uint64_t p_kill = sh->pushed.load();
  const int status = kill_child();
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
  const std::uint64_t p_end = sh->pushed.load();
  ::munmap(mem, sizeof(CrashShared));

  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  const std::uint64_t n = log->records.size();
  std::printf(
      "crash: first flush seen after %.3f s; %llu records on disk, %llu pushed at kill "
      "(lost %lld steps); warning: %s\n",
      flush_wait_s, static_cast<unsigned long long>(n), static_cast<unsigned long long>(p_kill),
      static_cast<long long>(p_kill) - static_cast<long long>(n),
      log->warning.empty() ? "none" : log->warning.c_str());
  EXPECT_GE(n, p_before) << "records pushed 0.2 s before the kill were lost";
  EXPECT_LE(n, p_end);
  for (std::uint64_t i = 0; i < n; ++i)
    ASSERT_TRUE(same_bits(log->records[i], make_record(i))) << "record " << i;
}

}  // namespace
}  // namespace dentar::haptics
