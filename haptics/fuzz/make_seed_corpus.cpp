// Writes the seed corpus of fuzz_session_log (corpus/fuzz_session_log/):
// small valid logs plus one example of each kind of damage the reader reports.
// The files are checked in; rebuild them after a format change with
//   cmake --build <build> --target haptics_fuzz_seeds &&
//   <build>/haptics/fuzz/make_seed_corpus haptics/fuzz/corpus/fuzz_session_log
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dentar/haptics/session_log.h"

namespace {

using dentar::haptics::encode_session_log_block;
using dentar::haptics::encode_session_log_header;
using dentar::haptics::StepRecord;

std::vector<StepRecord> records(std::uint64_t first, std::size_t n) {
  std::vector<StepRecord> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    StepRecord& r = v[i];
    r.step = first + i;
    r.time_s = 1e-3 * static_cast<double>(r.step);
    r.position_m[0] = 0.01 + 1e-5 * static_cast<double>(i);
    r.force_dev_N[2] = -0.5;
    r.contacts = static_cast<std::uint32_t>(3 * i);
    r.removed[1] = static_cast<std::uint32_t>(i);
    r.pedal = 1;
    r.flags = dentar::haptics::kFlagContact;
  }
  return v;
}

void save(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <corpus dir>\n", argv[0]);
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  const std::string json = R"({"kind":"molar","voxel_mm":0.1,"bur":"round_1.0"})";

  save(dir / "seed0", encode_session_log_header("{}"));
  save(dir / "seed1",
       encode_session_log_header(json) + encode_session_log_block(records(0, 1), 0, 0));
  const std::string three = encode_session_log_header(json) +
                            encode_session_log_block(records(0, 2), 0, 0) +
                            encode_session_log_block(records(2, 1), 2, 0) +
                            encode_session_log_block(records(5, 3), 3, 2);  // 2 dropped
  save(dir / "seed2", three);
  save(dir / "seed3", three.substr(0, three.size() - 100));  // truncated last block
  std::string flipped = three;
  flipped[three.size() - 300] ^= 0x10;  // payload byte of the last block: CRC mismatch
  save(dir / "seed4", flipped);
  std::string v2 = encode_session_log_header(json);
  v2[8] = 2;  // unsupported version
  save(dir / "seed5", v2);
  save(dir / "seed6", encode_session_log_header("") +
                          encode_session_log_block(records(0, 2), 0, 0) +
                          encode_session_log_block(records(2, 2), 7, 0));  // out of sequence
  std::printf("wrote 7 seeds to %s\n", dir.string().c_str());
  return 0;
}
