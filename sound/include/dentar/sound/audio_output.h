// Sound output through OpenAL Soft: a real device chosen by name, or the
// loopback device (ALC_SOFT_loopback) that mixes on demand with no sound card
// (tests, offline renders, benchmarks).
//
// Streaming: mono blocks of period_frames samples go into a ring of
// queue_buffers OpenAL buffers on one source, played as stereo with
// AL_DIRECT_CHANNELS_SOFT (no panning, no HRTF: left = right = the sample).
// Latency added here: up to queue_buffers periods queued ahead of the mixer,
// plus the device's own period (a real card: OpenAL Soft's period_size x
// periods, alsoft.conf; the loopback: the frames asked of render()).
//
// Thread: one AudioOutput is used by one thread at a time (the audio thread or
// the caller); the object makes its context current when it is created. One
// output per process at a time (OpenAL's current context is process-wide).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::sound {

struct AudioDeviceInfo {
  std::string name;
  bool is_default = false;
  bool opens = false;  // probed: alcOpenDevice succeeded
};
// The outputs OpenAL Soft enumerates, each probed (opened and closed again).
std::vector<AudioDeviceInfo> list_audio_outputs();

struct OutputOptions {
  int sample_rate_hz = 48000;
  // Samples per queued block: 128 (2.7 ms) keeps contact-to-sound under 20 ms at p99 on the
  // loopback (256 did not: 22 ms; docs/BENCHMARKS.md, issue 29).
  int period_frames = 128;
  int queue_buffers = 3;    // blocks queued ahead of the mixer (>= 2)
  std::string validate() const;
};

class AudioOutput {
 public:
  // The loopback device (no sound card needed). Errors: no ALC_SOFT_loopback, a
  // render format OpenAL Soft does not support.
  static Result<std::unique_ptr<AudioOutput>> open_loopback(const OutputOptions& o);
  // A device by its name ("" = the default). An unknown or absent device falls
  // back to the default, and `note` says so; when no device opens at all the
  // result is null and `note` is the warning to show (sound off, never an
  // error: the trainer runs silent).
  static std::unique_ptr<AudioOutput> open_device(const std::string& name, const OutputOptions& o,
                                                  std::string& note);
  ~AudioOutput();
  AudioOutput(const AudioOutput&) = delete;
  AudioOutput& operator=(const AudioOutput&) = delete;

  bool loopback() const { return loopback_; }
  const std::string& device_name() const { return name_; }
  const OutputOptions& options() const { return opt_; }

  // Blocks that may be queued now (processed buffers reclaimed). Allocation-free.
  int free_blocks();
  // Queues one block (period_frames mono samples) and starts the source when it
  // had stopped (first block, or after an underrun: counted).
  Status queue_block(const float* mono);
  std::size_t underruns() const { return underruns_; }
  // Loopback only: mixes `frames` stereo frames (interleaved floats) into out.
  void render(float* stereo_out, int frames);
  // The volume of the source (0..1), applied by OpenAL.
  void set_gain(double g);

 private:
  AudioOutput() = default;
  Status init_stream();

  OutputOptions opt_;
  bool loopback_ = false;
  std::string name_;
  void* device_ = nullptr;   // ALCdevice*
  void* context_ = nullptr;  // ALCcontext*
  unsigned source_ = 0;
  std::vector<unsigned> buffers_, free_;
  std::vector<float> stereo_;  // scratch, period_frames x 2
  std::size_t queued_ = 0, underruns_ = 0;
};

// Streams `mono` through the loopback mixer and returns what came out (the
// left channel), time-aligned with the input: sample i out is sample i in.
Result<std::vector<float>> render_through_openal(const std::vector<float>& mono, const OutputOptions& o = {});

}  // namespace dentar::sound
