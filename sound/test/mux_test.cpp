// Muxing the sound track into the composite video (issue 29): the result has
// one video stream (copied: the same packets) and one audio stream whose
// samples are the WAV's and whose duration is the video's; bad input gives a
// message naming it and leaves no file behind.
#include "dentar/sound/mux.h"

#include <gtest/gtest.h>

#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "dentar/sound/audio_file.h"
#include "testutil.h"

extern "C" {
#include <libavformat/avformat.h>
}

namespace dentar::sound {
namespace {

namespace fs = std::filesystem;

// A small MJPG Matroska video, as `dentar offline` writes composite.mkv.
void make_video(const fs::path& path, int frames, double fps) {
  cv::VideoWriter w(path.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, cv::Size(64, 48));
  ASSERT_TRUE(w.isOpened());
  for (int i = 0; i < frames; ++i) w.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar(i * 8 % 256, 40, 200)));
}

std::vector<float> tone(std::size_t n, int rate) {
  std::vector<float> s(n);
  for (std::size_t i = 0; i < n; ++i) s[i] = 0.5f * std::sin(2 * M_PI * 440.0 * static_cast<double>(i) / rate) + 0.1f * static_cast<float>(i % 7) / 7;
  return s;
}

// What the muxed file holds, read independently of mux.cpp (demuxing only: PCM needs no decoder).
struct Probe {
  int video_streams = 0, audio_streams = 0, video_frames = 0;
  double video_end_s = 0;
  AVCodecID audio_codec = AV_CODEC_ID_NONE;
  int rate = 0;
  std::vector<std::int16_t> samples;
  std::vector<std::string> video_packets;  // bytes of each video packet
};
Probe probe(const fs::path& path) {
  Probe p;
  AVFormatContext* c = nullptr;
  if (avformat_open_input(&c, path.c_str(), nullptr, nullptr) < 0) return p;
  avformat_find_stream_info(c, nullptr);
  int vs = -1, as = -1;
  for (unsigned i = 0; i < c->nb_streams; ++i) {
    const AVCodecParameters* par = c->streams[i]->codecpar;
    if (par->codec_type == AVMEDIA_TYPE_VIDEO) ++p.video_streams, vs = static_cast<int>(i);
    if (par->codec_type == AVMEDIA_TYPE_AUDIO) ++p.audio_streams, as = static_cast<int>(i), p.audio_codec = par->codec_id, p.rate = par->sample_rate;
  }
  AVPacket* k = av_packet_alloc();
  const AVRational fps = vs >= 0 ? c->streams[vs]->avg_frame_rate : AVRational{0, 1};
  while (av_read_frame(c, k) >= 0) {
    if (k->stream_index == vs) {
      ++p.video_frames;
      p.video_packets.emplace_back(reinterpret_cast<const char*>(k->data), static_cast<std::size_t>(k->size));
      const double t = static_cast<double>(k->pts) * av_q2d(c->streams[vs]->time_base) + (fps.num ? av_q2d(av_inv_q(fps)) : 0);
      p.video_end_s = std::max(p.video_end_s, t);
    } else if (k->stream_index == as) {
      const auto* d = reinterpret_cast<const std::int16_t*>(k->data);
      p.samples.insert(p.samples.end(), d, d + k->size / 2);
    }
    av_packet_unref(k);
  }
  av_packet_free(&k);
  avformat_close_input(&c);
  return p;
}

// The WAV's 16-bit samples, read back through libsndfile (read_audio gives them as s / 32768, exactly).
std::vector<std::int16_t> wav_pcm16(const fs::path& wav) {
  auto clip = read_audio(wav.string());
  EXPECT_TRUE(clip.ok());
  std::vector<std::int16_t> o;
  if (!clip) return o;
  for (float f : clip->mono) o.push_back(static_cast<std::int16_t>(std::lround(f * 32768.0)));
  return o;
}

TEST(Mux, OneVideoAndOneAudioStreamWithTheWavsSamplesAndTheVideosDuration) {
  const fs::path dir = dentar::test::temp_dir("mux");
  const int rate = 48000, frames = 30;
  const double fps = 30;
  make_video(dir / "composite.mkv", frames, fps);
  const Probe src = probe(dir / "composite.mkv");
  ASSERT_EQ(src.video_frames, frames);
  // A WAV a little shorter than the video (padded with silence) and one longer (cut).
  for (const std::size_t n : {std::size_t{47000}, std::size_t{52000}}) {
    const auto s = tone(n, rate);
    ASSERT_TRUE(write_wav((dir / "sound.wav").string(), s, rate).ok());
    const fs::path out = dir / ("composite_audio_" + std::to_string(n) + ".mkv");
    auto rep = mux_wav_into_video((dir / "composite.mkv").string(), (dir / "sound.wav").string(), out.string());
    ASSERT_TRUE(rep.ok()) << rep.error();
    EXPECT_EQ(rep->video_frames, frames);
    EXPECT_NEAR(rep->video_s, frames / fps, 1e-3);
    EXPECT_FALSE(fs::exists(out.string() + ".part"));
    const Probe p = probe(out);
    EXPECT_EQ(p.video_streams, 1);
    EXPECT_EQ(p.audio_streams, 1);
    EXPECT_EQ(p.audio_codec, AV_CODEC_ID_PCM_S16LE);
    EXPECT_EQ(p.rate, rate);
    // The video is copied: the same frames, byte for byte.
    ASSERT_EQ(p.video_frames, frames);
    EXPECT_EQ(p.video_packets, src.video_packets);
    // The sound lasts as long as the video, within one frame.
    const double audio_s = static_cast<double>(p.samples.size()) / rate;
    EXPECT_NEAR(audio_s, p.video_end_s, 1.0 / fps);
    EXPECT_NEAR(audio_s, frames / fps, 1.0 / fps);
    // The samples are the WAV's (16-bit, exactly), then silence where the WAV ended.
    const auto want = wav_pcm16(dir / "sound.wav");
    ASSERT_EQ(want.size(), n);
    const std::size_t common = std::min(want.size(), p.samples.size());
    ASSERT_GT(common, 40000u);
    EXPECT_TRUE(std::equal(want.begin(), want.begin() + static_cast<long>(common), p.samples.begin()));
    for (std::size_t i = common; i < p.samples.size(); ++i) ASSERT_EQ(p.samples[i], 0) << "sample " << i;
    if (n < 48000) {
      EXPECT_EQ(rep->padded_samples, 48000 - static_cast<long long>(n));
    } else {
      EXPECT_EQ(rep->trimmed_samples, static_cast<long long>(n) - 48000);
    }
  }
}

TEST(Mux, BadInputNamesItAndLeavesNoFile) {
  const fs::path dir = dentar::test::temp_dir("mux_bad");
  make_video(dir / "composite.mkv", 5, 30);
  ASSERT_TRUE(write_wav((dir / "sound.wav").string(), tone(4800, 48000), 48000).ok());
  // An unwritable output folder.
  const std::string nowhere = (dir / "no_such_folder" / "out.mkv").string();
  auto r = mux_wav_into_video((dir / "composite.mkv").string(), (dir / "sound.wav").string(), nowhere);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find(nowhere), std::string::npos) << r.error();
  EXPECT_FALSE(fs::exists(nowhere));
  EXPECT_FALSE(fs::exists(nowhere + ".part"));
  // No video: a missing file, and a file that is not a video (the WAV itself).
  const std::string out = (dir / "out.mkv").string();
  r = mux_wav_into_video((dir / "missing.mkv").string(), (dir / "sound.wav").string(), out);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("missing.mkv"), std::string::npos) << r.error();
  r = mux_wav_into_video((dir / "sound.wav").string(), (dir / "sound.wav").string(), out);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("no video stream"), std::string::npos) << r.error();
  // A sound track that is not audio.
  r = mux_wav_into_video((dir / "composite.mkv").string(), (dir / "composite.mkv").string(), out);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("sound track"), std::string::npos) << r.error();
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out + ".part"));
}

// `dentar offline --audio FILE.wav --audio-mux` end to end, on 12 frames of the built-in footage.
TEST(Mux, OfflineAudioMuxWritesTheCompositeWithItsSound) {
  const fs::path dir = dentar::test::temp_dir("mux_offline");
  const fs::path out = dir / "o", wav = dir / "drill.wav";
  auto r = dentar::test::run_dentar("offline --quiet --frames 12 --resolution 640x480 --no-score --out " + out.string() +
                                    " --audio " + wav.string() + " --audio-mux");
  ASSERT_EQ(r.code, 0) << r.out;
  const Probe video = probe(out / "composite.mkv");
  const Probe muxed = probe(out / "composite_audio.mkv");
  EXPECT_EQ(video.audio_streams, 0);  // composite.mkv itself is left as it was
  ASSERT_EQ(muxed.video_streams, 1);
  ASSERT_EQ(muxed.audio_streams, 1);
  EXPECT_EQ(muxed.video_packets, video.video_packets);
  ASSERT_EQ(muxed.video_frames, 12);
  const double frame_s = 1.0 / 30;
  const double audio_s = static_cast<double>(muxed.samples.size()) / muxed.rate;
  EXPECT_NEAR(audio_s, muxed.video_end_s, frame_s);
  // The rendered WAV itself already ends with the video (within a frame): the mux does not hide a misalignment.
  const auto want = wav_pcm16(wav);
  EXPECT_NEAR(static_cast<double>(want.size()) / 48000, muxed.video_end_s, frame_s);
  const std::size_t common = std::min(want.size(), muxed.samples.size());
  ASSERT_GT(common, 0u);
  EXPECT_TRUE(std::equal(want.begin(), want.begin() + static_cast<long>(common), muxed.samples.begin()));
  EXPECT_TRUE(std::any_of(want.begin(), want.end(), [](std::int16_t v) { return v != 0; }));  // the drill is heard

  // Bad arguments: exit 2, a message naming the option, and nothing written.
  r = dentar::test::run_dentar("offline --quiet --frames 12 --no-video --out " + (dir / "o2").string() + " --audio " +
                               wav.string() + " --audio-mux");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--audio-mux needs the video"), std::string::npos) << r.out;
  r = dentar::test::run_dentar("offline --quiet --frames 12 --out " + (dir / "o2").string() + " --audio-mux");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--audio-mux needs --audio"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "o2"));
}

}  // namespace
}  // namespace dentar::sound
