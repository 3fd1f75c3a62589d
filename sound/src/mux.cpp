#include "dentar/sound/mux.h"

#include <sndfile.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <system_error>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/channel_layout.h>
#include <libavutil/error.h>
#include <libavutil/mathematics.h>
}

namespace dentar::sound {
namespace {

std::string av_message(int err) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(err, buf, sizeof buf);
  return buf;
}

struct InputCloser {
  void operator()(AVFormatContext* c) const { avformat_close_input(&c); }
};
using Input = std::unique_ptr<AVFormatContext, InputCloser>;

struct PacketFree {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};
using Packet = std::unique_ptr<AVPacket, PacketFree>;

Result<Input> open_video(const std::string& path, int& stream) {
  AVFormatContext* raw = nullptr;
  if (int e = avformat_open_input(&raw, path.c_str(), nullptr, nullptr); e < 0)
    return Error{path + ": cannot open the video (" + av_message(e) + ")"};
  Input in(raw);
  if (int e = avformat_find_stream_info(in.get(), nullptr); e < 0)
    return Error{path + ": cannot read its streams (" + av_message(e) + ")"};
  stream = av_find_best_stream(in.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
  if (stream < 0) return Error{path + ": has no video stream (mux needs the composite video)"};
  return in;
}

// The WAV's samples, exactly as stored (16-bit PCM: no float round trip).
struct Pcm {
  std::vector<std::int16_t> interleaved;
  int rate = 0, channels = 0;
};
Result<Pcm> read_pcm16(const std::string& path) {
  SF_INFO info{};
  SNDFILE* f = sf_open(path.c_str(), SFM_READ, &info);
  if (!f) return Error{path + ": cannot read the sound track (" + sf_strerror(nullptr) + ")"};
  Pcm p;
  p.rate = info.samplerate;
  p.channels = info.channels;
  const bool pcm16 = (info.format & SF_FORMAT_SUBMASK) == SF_FORMAT_PCM_16;
  if (pcm16 && info.frames > 0) {
    p.interleaved.resize(static_cast<std::size_t>(info.frames) * info.channels);
    const sf_count_t got = sf_readf_short(f, p.interleaved.data(), info.frames);
    p.interleaved.resize(static_cast<std::size_t>(std::max<sf_count_t>(got, 0)) * info.channels);
  }
  sf_close(f);
  if (!pcm16) return Error{path + ": the sound track must be 16-bit PCM WAV (as dentar writes it)"};
  if (p.rate <= 0 || p.channels <= 0 || p.channels > 8) return Error{path + ": bad sample rate or channel count"};
  return p;
}

}  // namespace

Result<MuxReport> mux_wav_into_video(const std::string& video, const std::string& wav, const std::string& out) {
  namespace fs = std::filesystem;
  auto pcm = read_pcm16(wav);
  if (!pcm) return Error{pcm.error()};
  int vs = -1;
  // Pass 1: the video's duration (end of its last frame), to cut or pad the sound to it.
  MuxReport rep;
  {
    auto in = open_video(video, vs);
    if (!in) return Error{in.error()};
    const AVStream* st = (*in)->streams[vs];
    Packet pkt(av_packet_alloc());
    int64_t end = AV_NOPTS_VALUE;
    const AVRational fps = st->avg_frame_rate.num > 0 ? st->avg_frame_rate : st->r_frame_rate;
    const int64_t frame_tb = fps.num > 0 ? av_rescale_q(1, av_inv_q(fps), st->time_base) : 0;
    while (av_read_frame(in->get(), pkt.get()) >= 0) {
      if (pkt->stream_index == vs) {
        ++rep.video_frames;
        const int64_t t = pkt->pts != AV_NOPTS_VALUE ? pkt->pts : pkt->dts;
        if (t != AV_NOPTS_VALUE) end = std::max(end, t + (pkt->duration > 0 ? pkt->duration : frame_tb));
      }
      av_packet_unref(pkt.get());
    }
    if (rep.video_frames == 0 || end == AV_NOPTS_VALUE) return Error{video + ": the video has no frames"};
    rep.video_s = static_cast<double>(end) * av_q2d(st->time_base);
  }
  const long long want = std::llround(rep.video_s * pcm->rate);
  const long long have = static_cast<long long>(pcm->interleaved.size()) / pcm->channels;
  rep.audio_samples = want;
  rep.padded_samples = std::max(0LL, want - have);
  rep.trimmed_samples = std::max(0LL, have - want);
  pcm->interleaved.resize(static_cast<std::size_t>(want) * pcm->channels, 0);

  // Pass 2: copy the video, interleave the sound (chunks of 1024 samples, written up to each frame's time).
  auto in = open_video(video, vs);
  if (!in) return Error{in.error()};
  const std::string part = out + ".part";
  AVFormatContext* oc = nullptr;
  if (int e = avformat_alloc_output_context2(&oc, nullptr, "matroska", part.c_str()); e < 0 || !oc)
    return Error{"cannot set up the Matroska muxer (" + av_message(e) + ")"};
  bool opened = false, ok = false;
  std::string err;
  auto cleanup = [&] {
    if (opened) avio_closep(&oc->pb);
    avformat_free_context(oc);
    if (!ok) {
      std::error_code ec;
      fs::remove(part, ec);
    }
  };
  do {
    AVStream* ivs = (*in)->streams[vs];
    AVStream* ovs = avformat_new_stream(oc, nullptr);
    AVStream* oas = ovs ? avformat_new_stream(oc, nullptr) : nullptr;
    if (!oas) {
      err = "out of memory";
      break;
    }
    if (int e = avcodec_parameters_copy(ovs->codecpar, ivs->codecpar); e < 0) {
      err = video + ": cannot copy the video's parameters (" + av_message(e) + ")";
      break;
    }
    ovs->codecpar->codec_tag = 0;
    ovs->time_base = ivs->time_base;
    ovs->avg_frame_rate = ivs->avg_frame_rate;
    AVCodecParameters* ap = oas->codecpar;
    ap->codec_type = AVMEDIA_TYPE_AUDIO;
    ap->codec_id = AV_CODEC_ID_PCM_S16LE;
    ap->format = AV_SAMPLE_FMT_S16;
    ap->sample_rate = pcm->rate;
    av_channel_layout_default(&ap->ch_layout, pcm->channels);
    ap->bits_per_coded_sample = 16;
    ap->block_align = 2 * pcm->channels;
    ap->bit_rate = static_cast<int64_t>(pcm->rate) * 16 * pcm->channels;
    oas->time_base = AVRational{1, pcm->rate};
    if (int e = avio_open(&oc->pb, part.c_str(), AVIO_FLAG_WRITE); e < 0) {
      err = out + ": cannot write (" + av_message(e) + "); choose a folder you can write to";
      break;
    }
    opened = true;
    if (int e = avformat_write_header(oc, nullptr); e < 0) {
      err = out + ": cannot write the header (" + av_message(e) + ")";
      break;
    }
    Packet pkt(av_packet_alloc());
    long long next = 0;  // next audio sample to write
    constexpr long long kChunk = 1024;
    auto write_audio_until = [&](long long until) -> bool {
      until = std::min(until, want);
      while (next < until) {
        const long long n = std::min(kChunk, want - next);
        Packet a(av_packet_alloc());
        if (av_new_packet(a.get(), static_cast<int>(n * 2 * pcm->channels)) < 0) return false;
        std::memcpy(a->data, pcm->interleaved.data() + next * pcm->channels, static_cast<std::size_t>(n) * 2 * pcm->channels);
        a->stream_index = oas->index;
        a->pts = a->dts = next;
        a->duration = n;
        av_packet_rescale_ts(a.get(), AVRational{1, pcm->rate}, oas->time_base);
        if (int e = av_interleaved_write_frame(oc, a.get()); e < 0) {
          err = out + ": cannot write the sound (" + av_message(e) + ")";
          return false;
        }
        next += n;
      }
      return true;
    };
    bool failed = false;
    while (!failed && av_read_frame(in->get(), pkt.get()) >= 0) {
      if (pkt->stream_index == vs) {
        const int64_t t = pkt->pts != AV_NOPTS_VALUE ? pkt->pts : pkt->dts;
        if (t != AV_NOPTS_VALUE && !write_audio_until(av_rescale_q(t, ivs->time_base, AVRational{1, pcm->rate}))) {
          failed = true;
        } else {
          pkt->stream_index = ovs->index;
          av_packet_rescale_ts(pkt.get(), ivs->time_base, ovs->time_base);
          pkt->pos = -1;
          if (int e = av_interleaved_write_frame(oc, pkt.get()); e < 0) {
            err = out + ": cannot write the video (" + av_message(e) + ")";
            failed = true;
          }
        }
      }
      av_packet_unref(pkt.get());
    }
    if (failed || !write_audio_until(want)) {
      if (err.empty()) err = out + ": cannot write the sound";
      break;
    }
    if (int e = av_write_trailer(oc); e < 0) {
      err = out + ": cannot finish the file (" + av_message(e) + ")";
      break;
    }
    avio_closep(&oc->pb);
    opened = false;
    std::error_code ec;
    fs::rename(part, out, ec);
    if (ec) {
      err = out + ": cannot rename " + part + " to it (" + ec.message() + ")";
      break;
    }
    ok = true;
  } while (false);
  cleanup();
  if (!ok) return Error{err};
  return rep;
}

}  // namespace dentar::sound
