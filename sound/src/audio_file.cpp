#include "dentar/sound/audio_file.h"

#include <sndfile.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

namespace dentar::sound {
namespace {

struct SndCloser {
  void operator()(SNDFILE* f) const { sf_close(f); }
};
using SndFile = std::unique_ptr<SNDFILE, SndCloser>;

}  // namespace

Status write_wav(const std::string& path, const std::vector<float>& samples, int sample_rate_hz,
                 int channels) {
  if (channels < 1 || samples.size() % static_cast<std::size_t>(channels) != 0)
    return Error{path + ": " + std::to_string(samples.size()) + " samples do not make whole frames of " +
                 std::to_string(channels) + " channels"};
  SF_INFO info{};
  info.samplerate = sample_rate_hz;
  info.channels = channels;
  info.format = SF_FORMAT_WAV | SF_FORMAT_PCM_16;
  SndFile f(sf_open(path.c_str(), SFM_WRITE, &info));
  if (!f) return Error{path + ": cannot write a WAV file (" + sf_strerror(nullptr) + "); check the folder exists and is writable"};
  sf_command(f.get(), SFC_SET_CLIPPING, nullptr, SF_TRUE);
  sf_command(f.get(), SFC_SET_DITHER_ON_WRITE, nullptr, SF_FALSE);
  const auto frames = static_cast<sf_count_t>(samples.size() / static_cast<std::size_t>(channels));
  if (sf_writef_float(f.get(), samples.data(), frames) != frames)
    return Error{path + ": write failed (" + std::string(sf_strerror(f.get())) + ")"};
  return {};
}

Result<AudioClip> read_audio(const std::string& path, double max_seconds) {
  if (!std::filesystem::exists(path)) return Error{path + ": no such file"};
  SF_INFO info{};
  SndFile f(sf_open(path.c_str(), SFM_READ, &info));
  if (!f)
    return Error{path + ": not an audio file libsndfile can read (" + std::string(sf_strerror(nullptr)) +
                 "); give a WAV, FLAC, OGG or AIFF recording of the running drill"};
  if (info.frames <= 0 || info.channels <= 0 || info.samplerate <= 0)
    return Error{path + ": holds no audio frames"};
  if (static_cast<double>(info.frames) / info.samplerate > max_seconds)
    return Error{path + ": " + std::to_string(static_cast<double>(info.frames) / info.samplerate) +
                 " s long; a drill sample is looped, give at most " + std::to_string(max_seconds) + " s"};
  std::vector<float> inter(static_cast<std::size_t>(info.frames) * static_cast<std::size_t>(info.channels));
  const sf_count_t got = sf_readf_float(f.get(), inter.data(), info.frames);
  if (got <= 0) return Error{path + ": could not decode its audio (" + std::string(sf_strerror(f.get())) + ")"};
  AudioClip c;
  c.sample_rate_hz = info.samplerate;
  c.channels = info.channels;
  c.mono.resize(static_cast<std::size_t>(got));
  for (sf_count_t i = 0; i < got; ++i) {
    double s = 0;
    for (int ch = 0; ch < info.channels; ++ch)
      s += inter[static_cast<std::size_t>(i * info.channels + ch)];
    const double v = s / info.channels;
    c.mono[static_cast<std::size_t>(i)] = std::isfinite(v) ? static_cast<float>(v) : 0.0f;
  }
  return c;
}

std::vector<float> resample_linear(const std::vector<float>& in, double from_hz, double to_hz) {
  if (in.empty() || from_hz <= 0 || to_hz <= 0) return {};
  const auto n = static_cast<std::size_t>(std::max(1.0, std::floor(static_cast<double>(in.size()) * to_hz / from_hz)));
  std::vector<float> out(n);
  const double step = from_hz / to_hz;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = static_cast<double>(i) * step;
    const auto i0 = std::min(in.size() - 1, static_cast<std::size_t>(x));
    const std::size_t i1 = std::min(in.size() - 1, i0 + 1);
    const double fr = x - static_cast<double>(i0);
    out[i] = static_cast<float>((1.0 - fr) * in[i0] + fr * in[i1]);
  }
  return out;
}

}  // namespace dentar::sound
