// Muxing the drill's sound into the composite video (`dentar offline --audio-mux`,
// docs/BENCHMARKS.md, issue 29 session 12b).
//   ./build/sound/sound_mux_bench
// BM_Mux/<frames>: a 1280x720 MJPG Matroska video of <frames> frames at 30 fps (noise
// frames, about the size of composite.mkv's: ~55 kB each) and as many seconds of 48 kHz
// 16-bit mono sound, muxed into composite_audio.mkv (video copied, sound as PCM).
// Counters: video_s (seconds of video per mux), x_realtime (video seconds per wall second).
// Its scratch folder is removed at the end.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

#include "dentar/sound/audio_file.h"
#include "dentar/sound/mux.h"

namespace dentar::sound {
namespace {

namespace fs = std::filesystem;

fs::path scratch() {
  static const fs::path p = fs::temp_directory_path() / ("dentar_mux_bench_" + std::to_string(getpid()));
  return p;
}

void BM_Mux(benchmark::State& state) {
  const int frames = static_cast<int>(state.range(0));
  fs::create_directories(scratch());
  const fs::path video = scratch() / ("composite_" + std::to_string(frames) + ".mkv");
  const fs::path wav = scratch() / "drill.wav", out = scratch() / "composite_audio.mkv";
  {
    cv::VideoWriter w(video.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, cv::Size(1280, 720));
    cv::RNG rng(1);
    cv::Mat f(720, 1280, CV_8UC3);
    rng.fill(f, cv::RNG::UNIFORM, 60, 200);
    cv::GaussianBlur(f, f, cv::Size(0, 0), 3);
    for (int i = 0; i < frames; ++i) {
      cv::Mat g = f.clone();
      cv::circle(g, cv::Point(100 + 10 * i % 1000, 360), 80, cv::Scalar(240, 240, 240), -1);
      w.write(g);
    }
  }
  std::vector<float> s(static_cast<std::size_t>(frames) * 1600);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  for (auto& v : s) v = u(rng);
  if (!write_wav(wav.string(), s, 48000).ok()) state.SkipWithError("cannot write the WAV");
  double video_s = 0;
  for (auto _ : state) {
    auto r = mux_wav_into_video(video.string(), wav.string(), out.string());
    if (!r) {
      state.SkipWithError(r.error().c_str());
      break;
    }
    video_s = r->video_s;
  }
  state.counters["video_s"] = video_s;
  state.counters["x_realtime"] = benchmark::Counter(video_s * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["file_MB"] = static_cast<double>(fs::file_size(out)) / 1e6;
}
BENCHMARK(BM_Mux)->Arg(90)->Arg(900)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace dentar::sound

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::error_code ec;
  std::filesystem::remove_all(dentar::sound::scratch(), ec);
  return 0;
}
