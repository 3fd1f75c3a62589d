// The sound beside the real haptic engine: the engine's thread is unaffected
// (no allocation in its steps while the sound reads its snapshot), a session
// log renders to the same WAV every time, and the sound follows the material
// the engine cuts (enamel, then dentin) in the scripted access preparation.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/session_log.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/sound/analysis.h"
#include "dentar/sound/audio_file.h"
#include "dentar/sound/feed.h"
#include "dentar/sound/player.h"
#include "dentar/volume/procedural_tooth.h"
#include "testutil.h"

#include "alloc_counter.h"  // counts this thread's heap allocations

namespace dentar::sound {
namespace {

using namespace dentar::haptics;

const volume::VoxelVolume& base_tooth() {
  static const volume::VoxelVolume v = std::move(volume::make_molar({})).value();
  return v;
}

struct Rig {
  Station station = default_station();
  volume::VoxelVolume tooth = base_tooth().clone();
  volume::BurSamples bur;
  std::unique_ptr<SimulatedDevice> device;
  std::unique_ptr<Engine> engine;
  explicit Rig(SessionLogWriter* log = nullptr) {
    bur = std::move(volume::sample_bur(volume::BurParams::capsule(0.5, 3.0), 4000)).value();
    HandParams hand;
    hand.stiffness_N_per_m = kFingerRestStiffness_N_per_m;
    auto d = SimulatedDevice::create(to_hand_script(tip_script("access", 2.5, 7.0), station), {}, hand);
    EXPECT_TRUE(d.ok()) << d.error();
    device = std::move(d).value();
    EngineConfig cfg;
    cfg.T_tooth_dev = station.T_tooth_dev;
    cfg.T_sty_tip = station.T_sty_tip;
    auto e = Engine::create(cfg, *device, tooth, bur, log);
    EXPECT_TRUE(e.ok()) << e.error();
    engine = std::move(e).value();
  }
};

TEST(SoundWithEngine, NoAllocationInTheEngineStepsWithSoundOn) {
  Rig rig;
  auto out = AudioOutput::open_loopback({});
  ASSERT_TRUE(out.ok()) << out.error();
  SoundPlayer player(std::move(out).value(), default_drill_params(), [&rig] { return rig.engine->snapshot(); });
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> contacts_heard{0};
  std::thread audio([&] {  // the sound card: mixes a period, the player refills
    std::vector<float> stereo(2 * 256);
    while (!stop.load()) {
      player.output().render(stereo.data(), 256);
      player.pump();
      contacts_heard.store(player.synth().contact_onsets());
    }
  });
  {  // the counter counts this thread's allocations
    const long c0 = dentar::test::this_thread_allocations();
    std::vector<int> v(16);
    v[3] = 1;
    ASSERT_GE(dentar::test::this_thread_allocations() - c0, 1);
  }
  rig.engine->run_steps(10);  // warm-up outside the count (first-touch of lazily built state)
  const long before = dentar::test::this_thread_allocations();
  const std::uint64_t n = rig.engine->run_steps(4000);
  const long during = dentar::test::this_thread_allocations() - before;
  stop.store(true);
  audio.join();
  EXPECT_EQ(n, 4000u);
  EXPECT_EQ(during, 0) << "the engine allocated while the sound ran";
  EXPECT_GT(player.blocks(), 10u) << "the sound thread really ran beside the engine";
  EXPECT_GT(rig.engine->snapshot().contacts + contacts_heard.load(), 0u);
}

TEST(SoundWithEngine, SessionLogRendersTheSameWavEveryTimeAndFollowsTheMaterial) {
  const auto dir = test::temp_dir("session");
  const std::string path = (dir / "session.dlog").string();
  {
    Rig probe;
    auto w = SessionLogWriter::open(path, probe.engine->header_json(R"({"kind":"molar","voxel_mm":0.1})"));
    ASSERT_TRUE(w.ok()) << w.error();
    Rig rig(w->get());
    ASSERT_EQ(rig.engine->run_steps(11000), 11000u);
    ASSERT_TRUE((*w)->close().ok());
  }
  auto log = read_session_log(path);
  ASSERT_TRUE(log.ok()) << log.error();
  const DrillParams p = default_drill_params();
  auto a = render_session(*log, p);
  ASSERT_TRUE(a.ok()) << a.error();
  EXPECT_EQ(a->size(), 11000u * 48u) << "time-aligned: 48 samples per 1 kHz step";
  auto b = render_session(*log, p);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(*a, *b);
  // Through OpenAL's loopback into WAV twice: the same bytes.
  std::string bytes[2];
  for (int k = 0; k < 2; ++k) {
    auto mixed = render_through_openal(*a);
    ASSERT_TRUE(mixed.ok()) << mixed.error();
    std::string name = "r";
    name += std::to_string(k);
    name += ".wav";
    const std::string wav = (dir / name).string();
    ASSERT_TRUE(write_wav(wav, *mixed, 48000).ok());
    bytes[k] = test::read_file(wav);
  }
  ASSERT_GT(bytes[0].size(), 11000u * 48u * 2u);
  EXPECT_EQ(bytes[0], bytes[1]);
  EXPECT_GT(rms(a->data(), a->size()), 0.01);

  // The material the sound cuts, step by step, follows what the engine removed.
  DrillSynth s(p);
  std::array<int, kSoundMaterials> steps_cutting{};
  double rate = 1000;
  std::vector<float> scratch(48);
  bool pulp = false;
  int first_enamel = -1, first_dentin = -1;
  for (const auto& r : log->records) {
    DrillInput in = input_from_record(r, rate);
    pulp = pulp || ((r.flags & kFlagPulpTouched) && r.pedal);
    in.pulp_exposed = pulp;
    s.set_input(in);
    s.render(scratch.data(), scratch.size());
    const int m = s.cutting_material();
    if (m >= 0) ++steps_cutting[static_cast<std::size_t>(m)];
    if (m == 2 && first_dentin < 0) first_dentin = static_cast<int>(r.step);
    if (m == 1 && first_enamel < 0) first_enamel = static_cast<int>(r.step);
  }
  EXPECT_GT(steps_cutting[1], 100) << "enamel";
  EXPECT_GT(steps_cutting[2], 100) << "dentin";
  EXPECT_GE(first_enamel, 0);
  EXPECT_GT(first_dentin, first_enamel) << "the enamel is cut first";
  // (This script stops at the chamber roof: break-through is checked on scripted inputs
  // in drill_synth_test, BreakThroughIntoThePulpIsAStep.)
}

}  // namespace
}  // namespace dentar::sound
