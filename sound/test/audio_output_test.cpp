// Output through OpenAL Soft's loopback device (no sound card needed), WAV
// files through libsndfile, and the bad inputs: an unknown device, a user
// sample that is not audio.
#include "dentar/sound/audio_output.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dentar/sound/analysis.h"
#include "dentar/sound/audio_file.h"
#include "dentar/sound/drill_synth.h"
#include "testutil.h"

namespace dentar::sound {
namespace {

std::vector<float> drilling(double seconds) {
  DrillSynth s(default_drill_params());
  std::vector<float> out(static_cast<std::size_t>(seconds * 48000));
  for (std::size_t at = 0; at < out.size(); at += 48) {
    DrillInput in;
    in.time_s = static_cast<double>(at) / 48000;
    in.pedal = true;
    in.contact = in.time_s > 0.3;
    in.force_N = 1.0;
    in.removed[1] = in.contact ? 1.0 : 0.0;
    s.set_input(in);
    s.render(out.data() + at, std::min<std::size_t>(48, out.size() - at));
  }
  return out;
}

TEST(AudioOutput, LoopbackPassesTheDrillThroughTimeAligned) {
  const auto in = drilling(0.8);
  auto out = render_through_openal(in);
  ASSERT_TRUE(out.ok()) << out.error();
  ASSERT_EQ(out->size(), in.size());
  double max_diff = 0;
  for (std::size_t i = 0; i < in.size(); ++i) max_diff = std::max(max_diff, std::abs(double{(*out)[i]} - in[i]));
  // Direct channels at the device's rate: what OpenAL mixes out is the sample, in place.
  EXPECT_LT(max_diff, 1e-5);
  EXPECT_GT(rms(out->data(), out->size()), 0.05);
}

TEST(AudioOutput, OptionsAreValidated) {
  OutputOptions o;
  o.queue_buffers = 1;
  EXPECT_NE(o.validate().find("queue_buffers = 1"), std::string::npos);
  auto a = AudioOutput::open_loopback(o);
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().find("queue_buffers"), std::string::npos);
}

TEST(AudioOutput, UnknownDeviceFallsBackAndSaysSo) {
  std::string note;
  auto out = AudioOutput::open_device("no such sound card", {}, note);
  EXPECT_NE(note.find("'no such sound card' not found"), std::string::npos) << note;
  EXPECT_NE(note.find("falling back to the default"), std::string::npos) << note;
  if (!out) {  // this machine has no sound card: a warning, and sound off
    EXPECT_NE(note.find("sound is off"), std::string::npos) << note;
  } else {
    EXPECT_FALSE(out->loopback());
  }
}

TEST(AudioOutput, ListingTheOutputsNeverFails) {
  // Here: OpenAL lists ALSA's default, which does not open without a card.
  for (const auto& d : list_audio_outputs()) EXPECT_FALSE(d.name.empty());
}

TEST(AudioFile, WavRoundTrip) {
  const auto dir = test::temp_dir("wav");
  const auto in = drilling(0.2);
  const std::string path = (dir / "d.wav").string();
  ASSERT_TRUE(write_wav(path, in, 48000).ok());
  auto clip = read_audio(path);
  ASSERT_TRUE(clip.ok()) << clip.error();
  EXPECT_EQ(clip->sample_rate_hz, 48000);
  EXPECT_EQ(clip->channels, 1);
  ASSERT_EQ(clip->mono.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) ASSERT_NEAR(clip->mono[i], in[i], 1.0 / 32768 + 1e-6);
}

TEST(AudioFile, AUserSampleThatIsNotAudioIsRefused) {
  const auto dir = test::temp_dir("notaudio");
  const std::string path = (dir / "drill.wav").string();
  test::write_file(path, "this is a text file, not a recording\n");
  auto c = read_audio(path);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find(path), std::string::npos) << c.error();
  EXPECT_NE(c.error().find("not an audio file"), std::string::npos) << c.error();
  auto missing = read_audio((dir / "absent.wav").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("no such file"), std::string::npos);
}

TEST(AudioFile, WriteToAMissingFolderNamesTheFile) {
  const auto dir = test::temp_dir("nofolder");
  const std::string path = (dir / "absent" / "x.wav").string();
  const Status s = write_wav(path, {0.0f, 0.1f}, 48000);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find(path), std::string::npos) << s.error();
}

}  // namespace
}  // namespace dentar::sound
