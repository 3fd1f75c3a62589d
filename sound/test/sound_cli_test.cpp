// `dentar sound render` and `dentar devices` end to end: the same session log
// gives the same WAV bytes, bad input gets exit 2 and a message naming it, and a
// machine without a sound card lists its audio outputs with a warning (exit 0).
#include <gtest/gtest.h>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/session_log.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/volume/procedural_tooth.h"
#include "testutil.h"

namespace dentar::sound {
namespace {

using namespace dentar::haptics;

// A short real session: the engine drilling the coarse molar for 3 s.
std::string make_session(const std::filesystem::path& dir) {
  volume::MolarParams mp;
  mp.voxel_mm = 0.2;
  volume::VoxelVolume tooth = std::move(volume::make_molar(mp)).value();
  auto bur = std::move(volume::sample_bur(volume::BurParams::capsule(0.5, 3.0), 2000)).value();
  const Station st = default_station();
  HandParams hand;
  hand.stiffness_N_per_m = kFingerRestStiffness_N_per_m;
  auto dev = std::move(SimulatedDevice::create(to_hand_script(tip_script("access", 2.5, 3.0), st), {}, hand)).value();
  EngineConfig cfg;
  cfg.T_tooth_dev = st.T_tooth_dev;
  cfg.T_sty_tip = st.T_sty_tip;
  const std::string path = (dir / "session.dlog").string();
  std::string header;
  {
    auto probe = std::move(Engine::create(cfg, *dev, tooth, bur)).value();
    header = probe->header_json(R"({"kind":"molar","voxel_mm":0.2})");
  }
  auto w = std::move(SessionLogWriter::open(path, header)).value();
  auto e = std::move(Engine::create(cfg, *dev, tooth, bur, w.get())).value();
  e->run_steps(3000);
  EXPECT_TRUE(w->close().ok());
  return path;
}

std::string dentar() { return std::string(DENTAR_BINARY); }

TEST(SoundCli, RenderIsRepeatableAndBadInputIsExit2) {
  const auto dir = test::temp_dir("sound_cli");
  const std::string log = make_session(dir);
  const std::string a = (dir / "a.wav").string(), b = (dir / "b.wav").string();
  auto r = test::run_command(dentar() + " sound render " + log + " --out " + a);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("wrote " + a), std::string::npos) << r.out;
  r = test::run_command(dentar() + " sound render " + log + " --out " + b + " --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string wa = test::read_file(a), wb = test::read_file(b);
  ASSERT_GT(wa.size(), 3000u * 48u * 2u);
  EXPECT_EQ(wa, wb) << "the same session log renders the same WAV";

  r = test::run_command(dentar() + " sound render " + log + " --out " + a + " --volume 150");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--volume"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("150"), std::string::npos) << r.out;

  const std::string text = (dir / "drill.wav").string();
  test::write_file(text, "not audio\n");
  r = test::run_command(dentar() + " sound render " + log + " --out " + a + " --drill-sample " + text);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--drill-sample: " + text + ": not an audio file"), std::string::npos) << r.out;

  r = test::run_command(dentar() + " sound render " + (dir / "absent.dlog").string() + " --out " + a);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("absent.dlog: no such file"), std::string::npos) << r.out;

  r = test::run_command(dentar() + " sound render " + log + " --out " + (dir / "no" / "x.wav").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot write"), std::string::npos) << r.out;

  // Muted: a file of silence, the same length.
  const std::string m = (dir / "m.wav").string();
  r = test::run_command(dentar() + " sound render " + log + " --out " + m + " --mute --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string wm = test::read_file(m);
  ASSERT_EQ(wm.size(), wa.size());
  EXPECT_EQ(wm.find_first_not_of('\0', 44), std::string::npos) << "muted render is all zeros";
}

// --teach-force-limit exercise takes the exercise's excessive_force_N: with a copy of the molar
// access opening whose limit is 0.5 N, the render equals --teach-force-limit 0.5 (and not the
// shipped 3 N, nor no teacher).
TEST(SoundCli, TeacherTakesTheExercisesForceLimit) {
  const auto dir = test::temp_dir("sound_teach");
  const std::string log = make_session(dir);
  std::string ex = test::read_file(std::string(DENTAR_ASSETS_DIR) + "/exercises/molar_access_opening.json");
  const auto at = ex.find("\"excessive_force_N\": 3.0");
  ASSERT_NE(at, std::string::npos);
  ex.replace(at, std::string("\"excessive_force_N\": 3.0").size(), "\"excessive_force_N\": 0.5");
  const std::string exf = (dir / "low_limit.json").string();
  test::write_file(exf, ex);
  auto render = [&](const std::string& name, const std::string& args) {
    const std::string out = (dir / name).string();
    auto r = test::run_command(dentar() + " sound render " + log + " --out " + out + " " + args);
    EXPECT_EQ(r.code, 0) << r.out;
    return std::pair{test::read_file(out), r.out};
  };
  const auto [from_ex, said] = render("ex.wav", "--teach-force-limit exercise --exercise " + exf);
  EXPECT_NE(said.find("above 0.5 N (excessive_force_N of exercise " + exf + ")"), std::string::npos) << said;
  const auto number = render("n.wav", "--teach-force-limit 0.5 --quiet").first;
  const auto shipped = render("s.wav", "--teach-force-limit exercise --exercise molar_access_opening --quiet").first;
  const auto none = render("none.wav", "--quiet").first;
  ASSERT_GT(from_ex.size(), 3000u * 48u * 2u);
  EXPECT_EQ(from_ex, number);
  EXPECT_NE(from_ex, shipped);
  EXPECT_NE(from_ex, none) << "the session drills above 0.5 N: the teacher must be heard";

  // Bad input: no exercise, an exercise that does not exist, a limit that is neither.
  auto r = test::run_command(dentar() + " sound render " + log + " --out " + (dir / "x.wav").string() +
                             " --teach-force-limit exercise");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--teach-force-limit exercise: the session has no exercise"), std::string::npos) << r.out;
  r = test::run_command(dentar() + " sound render " + log + " --out " + (dir / "x.wav").string() +
                        " --teach-force-limit exercise --exercise no_such_exercise");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no_such_exercise"), std::string::npos) << r.out;
  r = test::run_command(dentar() + " sound render " + log + " --out " + (dir / "x.wav").string() +
                        " --teach-force-limit loud");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'loud'"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.wav"));
}

TEST(SoundCli, MaterialsWritesAClipAndASpectrogramEach) {
  const auto dir = test::temp_dir("materials");
  const auto r = test::run_command(dentar() + " sound materials --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* c : {"enamel", "dentin", "pulp", "breakthrough", "probe"}) {
    EXPECT_GT(std::filesystem::file_size(dir / (std::string(c) + ".wav")), 44u) << c;
    const std::string png = test::read_file(dir / (std::string(c) + ".png"));
    ASSERT_GT(png.size(), 8u) << c;
    EXPECT_EQ(png.substr(1, 3), "PNG") << c;
  }
}

TEST(SoundCli, DevicesListsAudioOutputsAndWarnsWhenNoneOpens) {
  const auto r = test::run_command(dentar() + " devices --no-open");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("Audio outputs (OpenAL Soft):"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("ALSA lib"), std::string::npos) << "library lines are held back:\n" << r.out;
}

}  // namespace
}  // namespace dentar::sound
