// Session log writer and reader. Format: docs/formats.md ("Session log").
#include "dentar/haptics/session_log.h"

#include <fcntl.h>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <sstream>
#include <system_error>
#include <thread>
#include <type_traits>

#include "spsc_ring.h"

namespace dentar::haptics {
namespace {

// The file stores records exactly as they sit in memory, so pin the layout:
// a compiler or edit that changes it must also bump kSessionLogVersion.
static_assert(std::endian::native == std::endian::little,
              "session log records are stored in native (little-endian) order");
static_assert(std::numeric_limits<double>::is_iec559, "records store IEEE 754 doubles");
static_assert(std::is_trivially_copyable_v<StepRecord> && std::is_standard_layout_v<StepRecord>);
static_assert(sizeof(StepRecord) == kStepRecordBytes && alignof(StepRecord) == 8);
static_assert(offsetof(StepRecord, step) == 0);
static_assert(offsetof(StepRecord, time_s) == 8);
static_assert(offsetof(StepRecord, position_m) == 16);
static_assert(offsetof(StepRecord, rotation) == 40);
static_assert(offsetof(StepRecord, velocity_m_per_s) == 112);
static_assert(offsetof(StepRecord, force_dev_N) == 136);
static_assert(offsetof(StepRecord, buttons) == 160);
static_assert(offsetof(StepRecord, contacts) == 164);
static_assert(offsetof(StepRecord, removed) == 168);
static_assert(offsetof(StepRecord, pedal) == 200);
static_assert(offsetof(StepRecord, bur_id) == 201);
static_assert(offsetof(StepRecord, flags) == 202);
static_assert(offsetof(StepRecord, reserved) == 203);

constexpr std::uint8_t kFileMagic[8] = {'D', 'E', 'N', 'T', 'A', 'R', 'S', 'L'};
constexpr std::uint8_t kBlockMagic[4] = {'S', 'L', 'B', 'K'};
// Most records one writer block holds: bounds the logger's preallocated
// buffer (~850 KB) and each write() call.
constexpr std::size_t kWriterMaxBlockRecords = 4096;
constexpr std::size_t kMaxRingCapacity = std::size_t{1} << 20;  // 218 MB of records

static_assert(kWriterMaxBlockRecords <= kMaxRecordsPerBlock);
static_assert(kMaxRecordsPerBlock * kStepRecordBytes <= std::numeric_limits<std::uint32_t>::max());

void put_u32(std::uint8_t* p, std::uint32_t v) { std::memcpy(p, &v, 4); }
void put_u64(std::uint8_t* p, std::uint64_t v) { std::memcpy(p, &v, 8); }
std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

// Standard CRC-32 (zlib/PNG/Ethernet); zlib takes 32-bit lengths.
std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t n) {
  const auto* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (n > 0) {
    const std::size_t chunk = std::min<std::size_t>(n, 1u << 30);
    c = ::crc32(c, p, static_cast<uInt>(chunk));
    p += chunk;
    n -= chunk;
  }
  return static_cast<std::uint32_t>(c);
}

std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

// Fills the block header in block[0, 32) and the CRC after the payload that
// already sits at block[32, 32 + count * 208). Returns the block's byte size.
std::size_t finish_block(std::uint8_t* block, std::size_t count, std::uint64_t first_index,
                         std::uint64_t dropped_total) {
  const std::size_t payload_bytes = count * kStepRecordBytes;
  std::memcpy(block, kBlockMagic, 4);
  put_u32(block + 4, static_cast<std::uint32_t>(count));
  put_u32(block + 8, static_cast<std::uint32_t>(payload_bytes));
  put_u32(block + 12, 0);  // reserved
  put_u64(block + 16, first_index);
  put_u64(block + 24, dropped_total);
  const std::uint32_t crc = crc32_update(0, block, kLogBlockHeaderBytes + payload_bytes);
  put_u32(block + kLogBlockHeaderBytes + payload_bytes, crc);
  return kLogBlockHeaderBytes + payload_bytes + kLogCrcBytes;
}

// write() until done; false with errno set on failure.
bool write_all(int fd, const std::uint8_t* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    if (w == 0) {
      errno = EIO;
      return false;
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

// fdatasync that accepts files which cannot be synced (pipes, /dev/null).
bool sync_data(int fd) {
  if (::fdatasync(fd) == 0) return true;
  return errno == EINVAL || errno == EROFS;
}

// ---------------------------------------------------------------- reading

// Random-access bytes: a memory buffer or a file read with pread, so a large
// log is never held twice in memory.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  // Reads exactly n bytes at off; on failure returns false and sets *err.
  virtual bool read(std::uint64_t off, void* dst, std::size_t n, std::string* err) = 0;
};

class MemorySource final : public ByteSource {
 public:
  MemorySource(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint64_t size() const override { return size_; }
  bool read(std::uint64_t off, void* dst, std::size_t n, std::string* err) override {
    if (off > size_ || n > size_ - off) {  // the parser checks first; defence in depth
      *err = "read past the end";
      return false;
    }
    if (n > 0) std::memcpy(dst, data_ + off, n);
    return true;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
};

class FileSource final : public ByteSource {
 public:
  FileSource(int fd, std::uint64_t size) : fd_(fd), size_(size) {}
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  std::uint64_t size() const override { return size_; }
  bool read(std::uint64_t off, void* dst, std::size_t n, std::string* err) override {
    auto* p = static_cast<std::uint8_t*>(dst);
    while (n > 0) {
      const ssize_t r = ::pread(fd_, p, n, static_cast<off_t>(off));
      if (r < 0) {
        if (errno == EINTR) continue;
        *err = errno_text(errno);
        return false;
      }
      if (r == 0) {  // shrank since fstat
        *err = "unexpected end of file";
        return false;
      }
      p += r;
      off += static_cast<std::uint64_t>(r);
      n -= static_cast<std::size_t>(r);
    }
    return true;
  }

 private:
  int fd_;
  std::uint64_t size_;
};

Result<SessionLog> parse(ByteSource& src, const std::string& name) {
  const std::uint64_t size = src.size();
  std::string err;
  SessionLog log;

  // File header.
  std::uint8_t fixed[kLogFileHeaderFixedBytes];
  const std::size_t got =
      static_cast<std::size_t>(std::min<std::uint64_t>(size, kLogFileHeaderFixedBytes));
  if (!src.read(0, fixed, got, &err)) return Error{name + ": cannot read session log: " + err};
  if (got < sizeof kFileMagic || std::memcmp(fixed, kFileMagic, sizeof kFileMagic) != 0)
    return Error{name + ": not a DentAR session log (byte offset 0: magic is not \"DENTARSL\")"};
  if (got < kLogFileHeaderFixedBytes)
    return Error{name + ": truncated session log header (" + std::to_string(got) + " of " +
                 std::to_string(kLogFileHeaderFixedBytes) + " fixed bytes)"};
  log.version = get_u32(fixed + 8);
  if (log.version != kSessionLogVersion)
    return Error{name + ": session log version " + std::to_string(log.version) +
                 " unsupported (this build reads version " + std::to_string(kSessionLogVersion) +
                 ")"};
  const std::uint32_t record_bytes = get_u32(fixed + 12);
  if (record_bytes != kStepRecordBytes)
    return Error{name + ": byte offset 12: record size " + std::to_string(record_bytes) +
                 " unsupported (version 1 stores " + std::to_string(kStepRecordBytes) +
                 "-byte records)"};
  const std::uint32_t json_bytes = get_u32(fixed + 16);
  if (json_bytes > kMaxHeaderJsonBytes)
    return Error{name + ": byte offset 16: header JSON length " + std::to_string(json_bytes) +
                 " exceeds the limit of " + std::to_string(kMaxHeaderJsonBytes) + " bytes"};
  const std::uint64_t header_bytes = kLogFileHeaderFixedBytes + json_bytes + kLogCrcBytes;
  if (size < header_bytes)
    return Error{name + ": truncated session log header (file has " + std::to_string(size) +
                 " bytes, the header needs " + std::to_string(header_bytes) + ")"};
  log.header_json.resize(json_bytes);
  std::uint8_t crc_bytes[kLogCrcBytes];
  if (!src.read(kLogFileHeaderFixedBytes, log.header_json.data(), json_bytes, &err) ||
      !src.read(kLogFileHeaderFixedBytes + json_bytes, crc_bytes, kLogCrcBytes, &err))
    return Error{name + ": cannot read session log header: " + err};
  const std::uint32_t stored = get_u32(crc_bytes);
  const std::uint32_t computed = crc32_update(crc32_update(0, fixed, sizeof fixed),
                                              log.header_json.data(), log.header_json.size());
  if (stored != computed)
    return Error{name + ": byte offset " + std::to_string(kLogFileHeaderFixedBytes + json_bytes) +
                 ": header CRC mismatch (stored " + hex32(stored) + ", computed " +
                 hex32(computed) + "): the file is corrupt"};

  // Blocks. Any damage ends the log there: later blocks cannot be trusted to
  // line up, and the writer only ever appends.
  std::uint64_t off = header_bytes;
  log.good_bytes = off;
  // Bounded by the file's size, so never absurd.
  log.records.reserve(static_cast<std::size_t>((size - off) / kStepRecordBytes));
  auto warn = [&](const std::string& reason) {
    log.warning = name + ": byte offset " + std::to_string(off) + ": " + reason + "; kept " +
                  std::to_string(log.records.size()) + " records from " +
                  std::to_string(log.good_blocks) + " good blocks before it";
  };
  while (off < size) {
    const std::uint64_t remaining = size - off;
    std::uint8_t hdr[kLogBlockHeaderBytes];
    if (remaining < kLogBlockHeaderBytes) {
      warn("truncated block header (" + std::to_string(remaining) + " of " +
           std::to_string(kLogBlockHeaderBytes) + " bytes)");
      break;
    }
    if (!src.read(off, hdr, sizeof hdr, &err)) {
      warn("read error: " + err);
      break;
    }
    if (std::memcmp(hdr, kBlockMagic, sizeof kBlockMagic) != 0) {
      warn("bad block magic (not \"SLBK\")");
      break;
    }
    const std::uint32_t count = get_u32(hdr + 4);
    const std::uint32_t payload_bytes = get_u32(hdr + 8);
    const std::uint64_t first_index = get_u64(hdr + 16);
    const std::uint64_t dropped_total = get_u64(hdr + 24);
    if (count == 0 || count > kMaxRecordsPerBlock) {
      warn("bad record count " + std::to_string(count) + " (must be in [1, " +
           std::to_string(kMaxRecordsPerBlock) + "])");
      break;
    }
    if (payload_bytes != std::uint64_t{count} * kStepRecordBytes) {
      warn("bad payload byte count " + std::to_string(payload_bytes) + " for " +
           std::to_string(count) + " records of " + std::to_string(kStepRecordBytes) + " bytes");
      break;
    }
    const std::uint64_t block_bytes = kLogBlockHeaderBytes + payload_bytes + kLogCrcBytes;
    if (remaining < block_bytes) {
      warn("truncated block (needs " + std::to_string(block_bytes) + " bytes, " +
           std::to_string(remaining) + " remain)");
      break;
    }
    const std::size_t before = log.records.size();
    log.records.resize(before + count);  // bounded: the bytes are in the file
    if (!src.read(off + kLogBlockHeaderBytes, log.records.data() + before, payload_bytes, &err) ||
        !src.read(off + kLogBlockHeaderBytes + payload_bytes, crc_bytes, kLogCrcBytes, &err)) {
      log.records.resize(before);
      warn("read error: " + err);
      break;
    }
    const std::uint32_t block_stored = get_u32(crc_bytes);
    const std::uint32_t block_computed =
        crc32_update(crc32_update(0, hdr, sizeof hdr), log.records.data() + before, payload_bytes);
    if (block_stored != block_computed) {
      log.records.resize(before);
      warn("block CRC mismatch (stored " + hex32(block_stored) + ", computed " +
           hex32(block_computed) + ")");
      break;
    }
    if (first_index != before) {
      log.records.resize(before);
      warn("block starts at record " + std::to_string(first_index) + " but " +
           std::to_string(before) + " records precede it (missing or repeated block)");
      break;
    }
    ++log.good_blocks;
    log.dropped = dropped_total;
    off += block_bytes;
    log.good_bytes = off;
  }
  log.records.shrink_to_fit();
  return log;
}

}  // namespace

Result<SessionLog> parse_session_log(const std::uint8_t* data, std::size_t size,
                                     const std::string& name) {
  MemorySource src(data, data ? size : 0);
  return parse(src, name);
}

Result<SessionLog> read_session_log(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error{path + ": cannot open session log: " + errno_text(errno)};
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    return Error{path + ": cannot stat session log: " + errno_text(e)};
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return Error{path + ": not a regular file, so not a session log"};
  }
  FileSource src(fd, static_cast<std::uint64_t>(st.st_size));
  return parse(src, path);
}

std::string encode_session_log_header(std::string_view header_json) {
  std::string out(kLogFileHeaderFixedBytes + header_json.size() + kLogCrcBytes, '\0');
  auto* p = reinterpret_cast<std::uint8_t*>(out.data());
  std::memcpy(p, kFileMagic, sizeof kFileMagic);
  put_u32(p + 8, kSessionLogVersion);
  put_u32(p + 12, static_cast<std::uint32_t>(kStepRecordBytes));
  put_u32(p + 16, static_cast<std::uint32_t>(header_json.size()));
  if (!header_json.empty())
    std::memcpy(p + kLogFileHeaderFixedBytes, header_json.data(), header_json.size());
  put_u32(p + kLogFileHeaderFixedBytes + header_json.size(),
          crc32_update(0, p, kLogFileHeaderFixedBytes + header_json.size()));
  return out;
}

std::string encode_session_log_block(std::span<const StepRecord> records, std::uint64_t first_index,
                                     std::uint64_t dropped_total) {
  const std::size_t n = records.size();
  assert(n >= 1 && n <= kMaxRecordsPerBlock &&
         "dentar::haptics::encode_session_log_block: 1..kMaxRecordsPerBlock records");
  std::string out(kLogBlockHeaderBytes + n * kStepRecordBytes + kLogCrcBytes, '\0');
  auto* p = reinterpret_cast<std::uint8_t*>(out.data());
  std::memcpy(p + kLogBlockHeaderBytes, records.data(), n * kStepRecordBytes);
  finish_block(p, n, first_index, dropped_total);
  return out;
}

std::string LogWriterOptions::validate() const {
  std::ostringstream os;
  if (ring_capacity < 2 || ring_capacity > kMaxRingCapacity ||
      (ring_capacity & (ring_capacity - 1)) != 0)
    os << "ring_capacity = " << ring_capacity << " must be a power of two in [2, "
       << kMaxRingCapacity << "]";
  else if (!std::isfinite(flush_interval_s) || flush_interval_s <= 0 || flush_interval_s > 0.1)
    os << "flush_interval_s = " << flush_interval_s << " s must be in (0, 0.1]";
  else if (block_records > kWriterMaxBlockRecords || block_records > ring_capacity / 2)
    os << "block_records = " << block_records << " must be 0 (cut by time) or at most "
       << std::min(kWriterMaxBlockRecords, ring_capacity / 2)
       << " (4096 and half the ring_capacity)";
  return os.str();
}

// ---------------------------------------------------------------- writing

struct SessionLogWriter::Impl {
  explicit Impl(std::size_t capacity) : ring(capacity) {}

  detail::SpscRing<StepRecord> ring;
  std::atomic<bool> stop{false};    // owner -> logger: drain and exit
  std::atomic<bool> closed{false};  // push() refuses once set
  std::atomic<std::uint64_t> written{0};
  std::atomic<std::uint64_t> dropped{0};

  // Set in open(), then read-only.
  std::string path;
  LogWriterOptions opt;
  int fd = -1;
  std::thread thread;

  // Logger thread only while it runs; read by close() after join().
  std::vector<std::uint8_t> block;  // preallocated: header, kWriterMaxBlockRecords, CRC
  std::size_t max_block_records = 0;
  std::uint64_t file_offset = 0;
  std::uint64_t next_index = 0;  // records in the file so far
  std::string error;             // first write failure
  std::uint64_t unwritten = 0;   // records drained after that failure

  // Owner thread only.
  bool done = false;
  Status status;

  void run();
  void drain(bool final);
  void write_block(std::size_t count);
};

void SessionLogWriter::Impl::run() {
  pthread_setname_np(pthread_self(), "dentar-log");
  using Clock = std::chrono::steady_clock;
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(opt.flush_interval_s));
  // Polling keeps the producer free of any wake-up syscall. A short slice
  // lets a filling ring be drained early; ~200 idle wake-ups/s cost little.
  const auto slice = std::clamp<Clock::duration>(interval / 8, std::chrono::microseconds(500),
                                                 std::chrono::milliseconds(5));
  const std::size_t high_water = ring.capacity() / 2;
  auto last_flush = Clock::now();
  while (!stop.load(std::memory_order_acquire)) {
    std::this_thread::sleep_for(slice);
    const auto now = Clock::now();
    // Flushing one slice early keeps the gap between blocks within interval.
    if (now - last_flush >= interval - slice || ring.size_approx() >= high_water) {
      last_flush = now;
      drain(false);
    }
  }
  drain(true);  // close(): the producer has stopped; write everything left
}

void SessionLogWriter::Impl::drain(bool final) {
  // Fixed-size blocks: only whole blocks until close(), so where a block ends
  // depends on the record count, never on when the logger woke up.
  const std::size_t per_block = opt.block_records > 0 ? opt.block_records : max_block_records;
  for (;;) {
    if (opt.block_records > 0 && !final && ring.size_approx() < per_block) return;
    std::size_t filled = 0;
    const std::size_t n =
        ring.consume(per_block, [&](const StepRecord* first, std::size_t count) {
          std::memcpy(block.data() + kLogBlockHeaderBytes + filled * kStepRecordBytes, first,
                      count * kStepRecordBytes);
          filled += count;
        });
    if (n == 0) return;
    write_block(n);
  }
}

void SessionLogWriter::Impl::write_block(std::size_t count) {
  if (!error.empty()) {  // the file ends in a bad block already; keep draining the ring
    unwritten += count;
    return;
  }
  const std::size_t bytes =
      finish_block(block.data(), count, next_index, dropped.load(std::memory_order_relaxed));
  if (!write_all(fd, block.data(), bytes)) {
    error = path + ": session log write failed at byte offset " + std::to_string(file_offset) +
            ": " + errno_text(errno);
    unwritten += count;
    return;
  }
  file_offset += bytes;
  next_index += count;
  written.fetch_add(count, std::memory_order_relaxed);
  if (opt.fsync && !sync_data(fd))
    error = path + ": session log fdatasync failed after byte offset " +
            std::to_string(file_offset) + ": " + errno_text(errno);
}

Result<std::unique_ptr<SessionLogWriter>> SessionLogWriter::open(const std::string& path,
                                                                 const std::string& header_json,
                                                                 const LogWriterOptions& opt) {
  if (const std::string e = opt.validate(); !e.empty())
    return Error{path + ": session log options: " + e};
  if (header_json.size() > kMaxHeaderJsonBytes)
    return Error{path + ": session log header JSON is " + std::to_string(header_json.size()) +
                 " bytes; the limit is " + std::to_string(kMaxHeaderJsonBytes)};
  std::unique_ptr<SessionLogWriter> w(new SessionLogWriter());
  w->path_ = path;
  try {
    w->impl_ = std::make_unique<Impl>(opt.ring_capacity);  // touches every slot now, not at 1 kHz
  } catch (const std::bad_alloc&) {
    return Error{path + ": cannot allocate a session log ring of " +
                 std::to_string(opt.ring_capacity) + " records"};
  }
  Impl& im = *w->impl_;
  im.path = path;
  im.opt = opt;
  im.max_block_records = std::min(opt.ring_capacity, kWriterMaxBlockRecords);
  im.block.resize(kLogBlockHeaderBytes + im.max_block_records * kStepRecordBytes + kLogCrcBytes);

  im.fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (im.fd < 0) {
    im.done = true;
    return Error{path + ": cannot create session log: " + errno_text(errno)};
  }
  const std::string header = encode_session_log_header(header_json);
  if (!write_all(im.fd, reinterpret_cast<const std::uint8_t*>(header.data()), header.size()) ||
      (opt.fsync && !sync_data(im.fd))) {
    const int e = errno;
    ::close(im.fd);
    im.done = true;
    return Error{path + ": cannot write session log header: " + errno_text(e)};
  }
  im.file_offset = header.size();
  try {
    im.thread = std::thread([&im] { im.run(); });
  } catch (const std::system_error& e) {
    ::close(im.fd);
    im.done = true;
    return Error{path + ": cannot start the session log thread: " + e.what()};
  }
  return w;
}

SessionLogWriter::~SessionLogWriter() { (void)close(); }

bool SessionLogWriter::push(const StepRecord& r) noexcept {
  Impl& im = *impl_;
  if (im.closed.load(std::memory_order_relaxed) || !im.ring.try_push(r)) {
    im.dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  return true;
}

Status SessionLogWriter::close() {
  if (!impl_) return {};
  Impl& im = *impl_;
  if (im.done) return im.status;
  im.done = true;
  im.closed.store(true, std::memory_order_relaxed);
  im.stop.store(true, std::memory_order_release);
  if (im.thread.joinable()) im.thread.join();
  std::string err = im.error;
  if (::close(im.fd) != 0 && err.empty())
    err = path_ + ": closing session log failed: " + errno_text(errno);
  im.fd = -1;
  if (!err.empty() && im.unwritten > 0)
    err += "; " + std::to_string(im.unwritten) + " records were not written";
  if (!err.empty()) im.status = Error{err};
  return im.status;
}

std::uint64_t SessionLogWriter::written() const {
  return impl_->written.load(std::memory_order_relaxed);
}
std::uint64_t SessionLogWriter::dropped() const {
  return impl_->dropped.load(std::memory_order_relaxed);
}

}  // namespace dentar::haptics
