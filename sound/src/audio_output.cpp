#include "dentar/sound/audio_output.h"

#include <AL/al.h>
#include <AL/alc.h>
#include <AL/alext.h>

#include <algorithm>
#include <cstring>

namespace dentar::sound {
namespace {

ALCdevice* dev(void* p) { return static_cast<ALCdevice*>(p); }
ALCcontext* ctx(void* p) { return static_cast<ALCcontext*>(p); }

std::vector<std::string> split_list(const ALCchar* s) {
  std::vector<std::string> out;
  while (s && *s) {
    out.emplace_back(s);
    s += std::strlen(s) + 1;
  }
  return out;
}

std::vector<std::string> device_names(std::string* default_name) {
  const bool all = alcIsExtensionPresent(nullptr, "ALC_ENUMERATE_ALL_EXT") == ALC_TRUE;
  auto names = split_list(alcGetString(nullptr, all ? ALC_ALL_DEVICES_SPECIFIER : ALC_DEVICE_SPECIFIER));
  if (default_name) {
    const ALCchar* d = alcGetString(nullptr, all ? ALC_DEFAULT_ALL_DEVICES_SPECIFIER : ALC_DEFAULT_DEVICE_SPECIFIER);
    *default_name = d ? d : "";
  }
  return names;
}

}  // namespace

std::string OutputOptions::validate() const {
  if (sample_rate_hz < 8000 || sample_rate_hz > 192000)
    return "sample_rate_hz = " + std::to_string(sample_rate_hz) + " must be in [8000, 192000]";
  if (period_frames < 16 || period_frames > 65536)
    return "period_frames = " + std::to_string(period_frames) + " must be in [16, 65536]";
  if (queue_buffers < 2 || queue_buffers > 64)
    return "queue_buffers = " + std::to_string(queue_buffers) + " must be in [2, 64]";
  return {};
}

std::vector<AudioDeviceInfo> list_audio_outputs() {
  std::string def;
  std::vector<AudioDeviceInfo> out;
  for (const auto& n : device_names(&def)) {
    AudioDeviceInfo i;
    i.name = n;
    i.is_default = n == def;
    if (ALCdevice* d = alcOpenDevice(n.c_str())) {
      i.opens = true;
      alcCloseDevice(d);
    }
    out.push_back(i);
  }
  return out;
}

Result<std::unique_ptr<AudioOutput>> AudioOutput::open_loopback(const OutputOptions& o) {
  if (std::string e = o.validate(); !e.empty()) return Error{"audio output: " + e};
  if (alcIsExtensionPresent(nullptr, "ALC_SOFT_loopback") != ALC_TRUE)
    return Error{"OpenAL: the ALC_SOFT_loopback extension is missing (install OpenAL Soft, libopenal1)"};
  auto open = reinterpret_cast<LPALCLOOPBACKOPENDEVICESOFT>(alcGetProcAddress(nullptr, "alcLoopbackOpenDeviceSOFT"));
  auto supported = reinterpret_cast<LPALCISRENDERFORMATSUPPORTEDSOFT>(
      alcGetProcAddress(nullptr, "alcIsRenderFormatSupportedSOFT"));
  if (!open || !supported) return Error{"OpenAL: ALC_SOFT_loopback functions not found"};
  std::unique_ptr<AudioOutput> a(new AudioOutput);
  a->opt_ = o;
  a->loopback_ = true;
  a->name_ = "OpenAL Soft loopback";
  a->device_ = open(nullptr);
  if (!a->device_) return Error{"OpenAL: cannot open the loopback device"};
  if (supported(dev(a->device_), o.sample_rate_hz, ALC_STEREO_SOFT, ALC_FLOAT_SOFT) != ALC_TRUE)
    return Error{"OpenAL loopback: stereo float at " + std::to_string(o.sample_rate_hz) + " Hz not supported"};
  const ALCint attrs[] = {ALC_FORMAT_CHANNELS_SOFT, ALC_STEREO_SOFT, ALC_FORMAT_TYPE_SOFT, ALC_FLOAT_SOFT,
                          ALC_FREQUENCY, o.sample_rate_hz, ALC_HRTF_SOFT, ALC_FALSE,
                          ALC_OUTPUT_LIMITER_SOFT, ALC_FALSE, 0};
  a->context_ = alcCreateContext(dev(a->device_), attrs);
  if (!a->context_) return Error{"OpenAL loopback: cannot create a context"};
  if (Status s = a->init_stream(); !s) return Error{s.error()};
  return a;
}

std::unique_ptr<AudioOutput> AudioOutput::open_device(const std::string& name, const OutputOptions& o,
                                                      std::string& note) {
  note.clear();
  if (std::string e = o.validate(); !e.empty()) {
    note = "audio output: " + e + "; sound is off";
    return nullptr;
  }
  std::string def;
  const auto names = device_names(&def);
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "'" : ", '") + n + "'";
  if (list.empty()) list = "none";
  ALCdevice* d = nullptr;
  std::string used;
  if (!name.empty()) {
    d = alcOpenDevice(name.c_str());
    used = name;
    if (!d)
      note = "audio device '" + name + "' not found or cannot be opened (found: " + list +
             "); falling back to the default device";
  }
  if (!d) {
    d = alcOpenDevice(nullptr);
    used = def.empty() ? "default" : def;
  }
  if (!d) {
    note += std::string(note.empty() ? "" : "; ") + "no audio output device could be opened (found: " + list +
            "): sound is off";
    return nullptr;
  }
  std::unique_ptr<AudioOutput> a(new AudioOutput);
  a->opt_ = o;
  a->device_ = d;
  a->name_ = used;
  const ALCint attrs[] = {ALC_FREQUENCY, o.sample_rate_hz, 0};
  a->context_ = alcCreateContext(d, attrs);
  if (!a->context_) {
    note += std::string(note.empty() ? "" : "; ") + "audio device '" + used + "': cannot create a context: sound is off";
    return nullptr;
  }
  if (Status s = a->init_stream(); !s) {
    note += std::string(note.empty() ? "" : "; ") + s.error() + ": sound is off";
    return nullptr;
  }
  if (!name.empty() && note.empty()) note = "audio output: '" + used + "'";
  else if (name.empty()) note = "audio output: default device '" + used + "'";
  else note += " '" + used + "'";
  return a;
}

Status AudioOutput::init_stream() {
  if (alcMakeContextCurrent(ctx(context_)) != ALC_TRUE) return Error{"OpenAL: cannot make the context current"};
  if (alIsExtensionPresent("AL_EXT_float32") != AL_TRUE) return Error{"OpenAL: AL_EXT_float32 missing"};
  alGetError();
  alGenSources(1, &source_);
  buffers_.resize(static_cast<std::size_t>(opt_.queue_buffers));
  alGenBuffers(opt_.queue_buffers, buffers_.data());
  if (alGetError() != AL_NO_ERROR) return Error{"OpenAL: cannot create the source and buffers"};
  free_ = buffers_;
  alSourcei(source_, AL_SOURCE_RELATIVE, AL_TRUE);
  alSource3f(source_, AL_POSITION, 0, 0, 0);
  alSourcei(source_, AL_DIRECT_CHANNELS_SOFT, AL_TRUE);
  alSourcef(source_, AL_GAIN, 1.0f);
  stereo_.assign(static_cast<std::size_t>(opt_.period_frames) * 2, 0.0f);
  return {};
}

AudioOutput::~AudioOutput() {
  if (context_) {
    alcMakeContextCurrent(ctx(context_));
    if (source_) {
      alSourceStop(source_);
      alSourcei(source_, AL_BUFFER, 0);
      alDeleteSources(1, &source_);
    }
    if (!buffers_.empty()) alDeleteBuffers(static_cast<ALsizei>(buffers_.size()), buffers_.data());
    alcMakeContextCurrent(nullptr);
    alcDestroyContext(ctx(context_));
  }
  if (device_) alcCloseDevice(dev(device_));
}

int AudioOutput::free_blocks() {
  ALint processed = 0;
  alGetSourcei(source_, AL_BUFFERS_PROCESSED, &processed);
  while (processed-- > 0) {
    ALuint b = 0;
    alSourceUnqueueBuffers(source_, 1, &b);
    free_.push_back(b);  // capacity reserved: buffers_.size() elements at most
    --queued_;
  }
  return static_cast<int>(free_.size());
}

Status AudioOutput::queue_block(const float* mono) {
  if (free_.empty()) return Error{"AudioOutput::queue_block: no free buffer (call free_blocks first)"};
  const auto n = static_cast<std::size_t>(opt_.period_frames);
  for (std::size_t i = 0; i < n; ++i) stereo_[2 * i] = stereo_[2 * i + 1] = mono[i];
  const ALuint b = free_.back();
  free_.pop_back();
  alBufferData(b, AL_FORMAT_STEREO_FLOAT32, stereo_.data(), static_cast<ALsizei>(n * 2 * sizeof(float)),
               opt_.sample_rate_hz);
  alSourceQueueBuffers(source_, 1, &b);
  ++queued_;
  ALint state = 0;
  alGetSourcei(source_, AL_SOURCE_STATE, &state);
  if (state != AL_PLAYING) {
    if (state == AL_STOPPED) ++underruns_;
    alSourcePlay(source_);
  }
  if (alGetError() != AL_NO_ERROR) return Error{"OpenAL: queueing a block failed"};
  return {};
}

void AudioOutput::render(float* stereo_out, int frames) {
  static auto render_fn =
      reinterpret_cast<LPALCRENDERSAMPLESSOFT>(alcGetProcAddress(nullptr, "alcRenderSamplesSOFT"));
  if (loopback_ && render_fn) render_fn(dev(device_), stereo_out, frames);
}

void AudioOutput::set_gain(double g) { alSourcef(source_, AL_GAIN, static_cast<ALfloat>(g)); }

Result<std::vector<float>> render_through_openal(const std::vector<float>& mono, const OutputOptions& o) {
  auto out = AudioOutput::open_loopback(o);
  if (!out) return Error{out.error()};
  AudioOutput& a = **out;
  const auto p = static_cast<std::size_t>(o.period_frames);
  const std::size_t blocks = (mono.size() + p - 1) / p;
  std::vector<float> block(p), stereo(2 * p), result;
  result.reserve(blocks * p);
  std::size_t next = 0;
  auto feed = [&] {
    while (next < blocks && a.free_blocks() > 0) {
      std::fill(block.begin(), block.end(), 0.0f);
      const std::size_t n = std::min(p, mono.size() - next * p);
      std::copy_n(mono.begin() + static_cast<std::ptrdiff_t>(next * p), n, block.begin());
      if (Status s = a.queue_block(block.data()); !s) return s;
      ++next;
    }
    return Status{};
  };
  for (std::size_t k = 0; k < blocks; ++k) {
    if (Status s = feed(); !s) return Error{s.error()};
    a.render(stereo.data(), o.period_frames);
    for (std::size_t i = 0; i < p; ++i) result.push_back(stereo[2 * i]);
  }
  if (a.underruns() > 0) return Error{"OpenAL loopback: the stream ran dry " + std::to_string(a.underruns()) + " times"};
  result.resize(mono.size());
  return result;
}

}  // namespace dentar::sound
