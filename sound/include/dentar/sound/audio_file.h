// Audio files through libsndfile: writing renders (WAV) and reading an
// optional user sample of the drill. Errors name the file and what to do.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::sound {

// Writes mono or interleaved samples in [-1, 1] as 16-bit PCM WAV (dithering
// off, clipping on: the same samples always give the same bytes).
Status write_wav(const std::string& path, const std::vector<float>& samples, int sample_rate_hz,
                 int channels = 1);

struct AudioClip {
  std::vector<float> mono;  // channels averaged
  int sample_rate_hz = 0;
  int channels = 0;  // in the file
};
// Reads any format libsndfile knows (WAV, FLAC, OGG, AIFF, ...). Not audio,
// empty, or longer than max_seconds: an error naming the file.
Result<AudioClip> read_audio(const std::string& path, double max_seconds = 60.0);

// Linear-interpolation resampling (user samples to the output rate).
std::vector<float> resample_linear(const std::vector<float>& in, double from_hz, double to_hz);

}  // namespace dentar::sound
