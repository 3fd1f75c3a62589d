// The engine's threads together: the 1 kHz haptic thread (device, force
// model, cutter, guard, log push), the logger thread writing the session log,
// and a graphics-side thread reading snapshots as fast as it can. Built a
// second time with -fsanitize=thread (ctest label "tsan").
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"
#include "scripted_rig.h"
#include "testutil.h"

namespace dentar::haptics {
namespace {

void threads_run_together(bool overlap_cut) {
  test::ScriptedRig rig(0.2, 2000);
  if (overlap_cut) use_overlap_cut(rig.cfg);
  const volume::VoxelVolume start = rig.tooth.clone();
  rig.cfg.watchdog_missed_deadlines = 1000000;  // sanitizer slowness is not a fault here
  const auto dir = test::temp_dir("engine_tsan");
  const std::string path = (dir / "s.dlog").string();
  std::string header;
  {
    auto probe = rig.engine();
    header = probe->header_json(R"({"kind":"molar","voxel_mm":0.2})");
  }
  auto log = std::move(SessionLogWriter::open(path, header)).value();
  auto engine = rig.engine(log.get());

  std::atomic<bool> stop{false};
  std::uint64_t reads = 0, last_step = 0;
  bool monotonic = true;
  // Graphics side: starts after start() and ends before stop(), the
  // documented contract for stats() from another thread.
  ASSERT_TRUE(engine->start().ok());
  std::thread reader([&] {
    while (!stop.load()) {
      const HapticSnapshot s = engine->snapshot();
      monotonic &= s.step >= last_step;
      last_step = s.step;
      ++reads;
      (void)engine->stats();  // only `steps` while running; must not race
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  stop = true;
  reader.join();
  engine->stop();
  ASSERT_TRUE(log->close().ok());

  const EngineStats s = engine->stats();
  EXPECT_GT(s.steps, 50u);
  EXPECT_GT(reads, 100u);
  EXPECT_TRUE(monotonic);
  EXPECT_EQ(log->written() + log->dropped(), s.steps);
  // What the threads wrote is consistent: the log replays to the same volume.
  auto rec = read_session_log(path);
  ASSERT_TRUE(rec.ok()) << rec.error();
  EXPECT_EQ(rec->records.size(), s.steps);
  volume::VoxelVolume fresh = start.clone();
  auto r = replay_session(*rec, fresh);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->volume_hash, rig.tooth.content_hash());
}

TEST(EngineConcurrency, HapticThreadLoggerAndSnapshotReadersRunTogether) { threads_run_together(false); }
// The overlap cutter and the shape-constrained proxy (use_overlap_cut, `dentar live`'s).
TEST(EngineConcurrency, WithTheOverlapCutTheThreadsRunTogether) { threads_run_together(true); }

}  // namespace
}  // namespace dentar::haptics
