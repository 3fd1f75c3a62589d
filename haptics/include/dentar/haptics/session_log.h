// Session log: every haptic step, recorded for replay and assessment.
//
// The haptic thread pushes fixed-size StepRecords into a lock-free
// single-producer/single-consumer ring; a logger thread drains it and appends
// checksummed blocks to a binary file at least every flush_interval_s
// (<= 100 ms), so a crash loses at most the last interval. Readers accept a
// truncated or corrupt file up to its last good block and say so in a warning.
// Format: docs/formats.md ("Session log").
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::haptics {

// One haptic step. Plain data, written to the file as is (little endian,
// IEEE 754 doubles; layout pinned by static_asserts in session_log.cpp). The
// full rotation matrix is stored, not a quaternion, so replay is bit-exact.
struct StepRecord {
  std::uint64_t step = 0;
  double time_s = 0;                                 // device time
  double position_m[3] = {0, 0, 0};                  // T_dev_sty translation
  double rotation[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // T_dev_sty rotation, row major
  double velocity_m_per_s[3] = {0, 0, 0};            // device frame
  double force_dev_N[3] = {0, 0, 0};                 // force sent to the device
  std::uint32_t buttons = 0;
  std::uint32_t contacts = 0;     // immersed bur samples
  std::uint32_t removed[8] = {};  // density units removed this step, per material label 0..7
  std::uint8_t pedal = 0;
  std::uint8_t bur_id = 0;
  std::uint8_t flags = 0;  // kFlag* bits
  std::uint8_t reserved[5] = {};
};

inline constexpr std::uint8_t kFlagDeviceFault = 1u << 0;
inline constexpr std::uint8_t kFlagWatchdog = 1u << 1;  // zero force sent by the watchdog
inline constexpr std::uint8_t kFlagClamped = 1u << 2;   // force clamped or rate limited
inline constexpr std::uint8_t kFlagPulpTouched = 1u << 3;
inline constexpr std::uint8_t kFlagContact = 1u << 4;

// File format constants (docs/formats.md, "Session log").
inline constexpr std::uint32_t kSessionLogVersion = 1;
inline constexpr std::size_t kStepRecordBytes = 208;         // sizeof(StepRecord) on disk
inline constexpr std::size_t kLogFileHeaderFixedBytes = 20;  // magic, version, record size, length
inline constexpr std::size_t kLogBlockHeaderBytes = 32;
inline constexpr std::size_t kLogCrcBytes = 4;
// Limits a reader enforces before allocating; a writer never exceeds them.
inline constexpr std::size_t kMaxHeaderJsonBytes = std::size_t{1} << 20;
inline constexpr std::size_t kMaxRecordsPerBlock = std::size_t{1} << 16;

struct SessionLog {
  std::uint32_t version = 0;
  std::string header_json;  // engine configuration, as given to the writer (opaque bytes)
  std::vector<StepRecord> records;
  // Non-empty when the file was truncated or corrupt after the header: names
  // the file, the byte offset of the first bad block and the reason.
  std::string warning;
  std::size_t good_blocks = 0;
  std::uint64_t dropped = 0;     // records the writer dropped (ring full) up to the last good block
  std::uint64_t good_bytes = 0;  // header + good blocks; truncating the file here repairs it
};

// Reads a whole log (streams it block by block; memory is bounded by the
// records kept). Errors (no such file, not a session log, unsupported version,
// corrupt header) name the file; damage after the header gives the records of
// all good blocks plus a warning naming the offset.
Result<SessionLog> read_session_log(const std::string& path);
// Same, from memory (fuzz target, tests). `name` appears in messages. Never
// reads outside [data, data + size).
Result<SessionLog> parse_session_log(const std::uint8_t* data, std::size_t size,
                                     const std::string& name);

// Encoders for tests, tools and seed corpora (they allocate: not for the
// haptic thread). A file is one header followed by blocks whose first_index
// is the number of records before them.
std::string encode_session_log_header(std::string_view header_json);
// `records` must hold 1..kMaxRecordsPerBlock records.
std::string encode_session_log_block(std::span<const StepRecord> records, std::uint64_t first_index,
                                     std::uint64_t dropped_total);

struct LogWriterOptions {
  std::size_t ring_capacity = 1 << 14;  // records (16 s at 1 kHz); power of two in [2, 2^24]
  double flush_interval_s = 0.05;       // (0, 0.1] s: bounds what a crash can lose
  bool fsync = true;                    // fdatasync each block (survives power loss)
  // 0: blocks are cut by wall time (every flush, whatever the ring holds), as a
  // live session needs. N > 0: every block holds exactly N records (the last one
  // the rest), so the same records give the same bytes whatever the timing
  // (offline generation: the cohort generator). A crash then loses up to N
  // records more. At most 4096 and at most ring_capacity / 2.
  std::size_t block_records = 0;

  // Empty, or a message naming the field and the constraint.
  std::string validate() const;
};

// Owns the file, the ring and the logger thread. Thread use: push() from one
// producer thread (the haptic thread); everything else from the owning thread.
class SessionLogWriter {
 public:
  // Creates/truncates the file, writes (and syncs) the header and starts the
  // logger thread. Errors name the file (or the invalid option).
  static Result<std::unique_ptr<SessionLogWriter>> open(const std::string& path,
                                                        const std::string& header_json,
                                                        const LogWriterOptions& opt = {});
  ~SessionLogWriter();  // close(); an error is lost, so call close() yourself
  SessionLogWriter(const SessionLogWriter&) = delete;
  SessionLogWriter& operator=(const SessionLogWriter&) = delete;

  // Haptic thread: lock-free, wait-free, allocation- and syscall-free. Returns
  // false if the ring is full or the writer is closed (the record is dropped
  // and counted; never blocks).
  bool push(const StepRecord& r) noexcept;
  // Drains the ring, writes the last block, stops the thread, closes the file.
  // Call it after the producer has stopped pushing. Returns an error naming the
  // file and offset if any write failed; idempotent (later calls return the
  // same status).
  Status close();

  std::uint64_t written() const;  // records written to the file so far (any thread)
  std::uint64_t dropped() const;  // records refused by push() so far (any thread)
  const std::string& path() const { return path_; }

 private:
  SessionLogWriter() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string path_;
};

}  // namespace dentar::haptics
