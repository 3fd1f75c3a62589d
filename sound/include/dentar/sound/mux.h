// Muxing a session's sound track into its video (issue 29: `dentar offline
// --audio FILE.wav --audio-mux`), through FFmpeg's libavformat (Debian 12: 5.1).
#pragma once

#include <string>

#include "dentar/volume/result.h"

namespace dentar::sound {

struct MuxReport {
  int video_frames = 0;      // video packets copied
  double video_s = 0;        // the video's duration (end of its last frame)
  long long audio_samples = 0;  // per channel, written
  long long padded_samples = 0;   // silence added at the end (the WAV was shorter)
  long long trimmed_samples = 0;  // WAV samples past the video's end, left out
};

// Writes `out` (Matroska): the first video stream of `video` copied packet by
// packet (no re-encoding, same timestamps) and the 16-bit PCM samples of `wav`
// as a second stream, sample i at i / rate s (both start at 0, as `dentar
// offline` aligns them). The audio is cut or padded with silence to the
// video's duration, so both end together. The file is written beside `out` as
// `out`.part and renamed at the end: on any error nothing is left at `out`
// (nor the part). Errors name the file and what failed.
Result<MuxReport> mux_wav_into_video(const std::string& video, const std::string& wav, const std::string& out);

}  // namespace dentar::sound
