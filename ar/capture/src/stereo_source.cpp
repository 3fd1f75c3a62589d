#include "dentar/ar/stereo_source.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace dentar::ar {

namespace {

bool is_live_spec(const std::string& s) {
  return s.rfind("camera:", 0) == 0 || s.rfind("/dev/video", 0) == 0 || s.rfind("live:", 0) == 0;
}

std::string size_str(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

std::string num(double v, int prec = 1) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = p * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(std::floor(pos));
  const std::size_t j = std::min(i + 1, v.size() - 1);
  return v[i] + (pos - static_cast<double>(i)) * (v[j] - v[i]);
}

constexpr std::size_t kMaxSkewSamples = 1u << 20;  // ~9 h at 30 fps

}  // namespace

struct StereoSource::Eye {
  std::string spec, name;  // name: "left eye" / "right eye" / "side-by-side device"
  std::unique_ptr<CaptureThread> thread;  // live
  std::unique_ptr<FrameSource> file;      // recorded
  bool file_ended = false;
  bool has_pending = false;
  Frame pending;
  double opened_steady_s = 0;
  bool ended() const { return thread ? thread->ended() : file_ended; }
};

StereoSource::StereoSource() = default;
StereoSource::~StereoSource() {
  if (left_ && left_->thread) left_->thread->stop();
  if (right_ && right_->thread) right_->thread->stop();
}

std::string StereoSourceOptions::validate() const {
  if (auto e = source.validate(); !e.empty()) return "source." + e;
  if (!std::isfinite(max_skew_s) || max_skew_s < 0 || max_skew_s > 1)
    return "max_skew_s = " + std::to_string(max_skew_s) + " s must be in [0, 1] (0 = half a frame period)";
  if (!std::isfinite(single_after_s) || single_after_s <= 0 || single_after_s > 5)
    return "single_after_s = " + std::to_string(single_after_s) + " s must be in (0, 5]";
  return {};
}

std::string StereoCaptureStats::summary() const {
  std::ostringstream os;
  os << "stereo capture: " << pairs << " pairs, " << left_only << " left-only, " << right_only
     << " right-only frames; pairing skew p50 " << num(skew_p50_ms, 2) << " p95 " << num(skew_p95_ms, 2)
     << " max " << num(skew_max_ms, 2) << " ms; dropped unpaired " << unpaired_left << " L / "
     << unpaired_right << " R, by the source " << source_dropped_left << " L / " << source_dropped_right
     << " R, replaced before read " << consumer_dropped_left << " L / " << consumer_dropped_right << " R";
  if (fallbacks > 0)
    os << "; " << fallbacks << " fallback(s) to one eye (longest " << num(fallback_latency_max_ms, 0)
       << " ms after the eye's last frame), " << recoveries << " recovered";
  return os.str();
}

Result<std::unique_ptr<StereoSource>> StereoSource::open_pair(const std::string& left_spec,
                                                              const std::string& right_spec,
                                                              const StereoSourceOptions& options) {
  if (auto e = options.validate(); !e.empty()) return Error{"StereoSourceOptions: " + e};
  if (left_spec.empty() || right_spec.empty())
    return Error{"stereo capture: give two sources, the left eye and the right eye (got '" + left_spec +
                 "' and '" + right_spec + "')"};
  if (left_spec == right_spec)
    return Error{"stereo capture: the left and right eye are the same source (" + left_spec +
                 "); give two cameras, or one side-by-side device"};
  const bool live_l = is_live_spec(left_spec), live_r = is_live_spec(right_spec);
  if (live_l != live_r)
    return Error{"stereo capture: the left eye " + left_spec + " is " + (live_l ? "live" : "a recording") +
                 " but the right eye " + right_spec + " is " + (live_r ? "live" : "a recording") +
                 "; both eyes must be cameras (or live: stand-ins), or both recordings"};
  auto l = FrameSource::open(left_spec, options.source);
  if (!l) return Error{"left eye: " + l.error()};
  auto r = FrameSource::open(right_spec, options.source);
  if (!r) return Error{"right eye: " + r.error()};
  const FrameSource& L = **l;
  const FrameSource& R = **r;
  if (L.width() != R.width() || L.height() != R.height())
    return Error{"stereo capture: the left eye " + L.description() + " is " + size_str(L.width(), L.height()) +
                 " but the right eye " + R.description() + " is " + size_str(R.width(), R.height()) +
                 "; both cameras must deliver one size (request it with the width/height options)"};
  if (std::abs(L.fps() - R.fps()) > 0.01 * std::max(L.fps(), R.fps()))
    return Error{"stereo capture: the left eye " + L.description() + " runs at " + num(L.fps(), 2) +
                 " fps but the right eye " + R.description() + " at " + num(R.fps(), 2) +
                 " fps; pairs need one rate (request it with the fps option)"};
  auto s = std::unique_ptr<StereoSource>(new StereoSource);
  s->options_ = options;
  s->live_ = live_l;
  s->width_ = L.width();
  s->height_ = L.height();
  s->fps_ = L.fps() > 0 ? L.fps() : 30;
  s->max_skew_s_ = options.max_skew_s > 0 ? options.max_skew_s : 0.5 / s->fps_;
  s->left_ = std::make_unique<Eye>();
  s->right_ = std::make_unique<Eye>();
  s->left_->spec = left_spec;
  s->left_->name = "left eye";
  s->right_->spec = right_spec;
  s->right_->name = "right eye";
  if (s->live_) {
    s->left_->thread = std::make_unique<CaptureThread>(std::move(*l), left_spec, options.source, options.left_capture);
    s->right_->thread =
        std::make_unique<CaptureThread>(std::move(*r), right_spec, options.source, options.right_capture);
    s->left_->thread->start();
    s->right_->thread->start();
    s->left_->opened_steady_s = s->right_->opened_steady_s = steady_now_s();
  } else {
    s->left_->file = std::move(*l);
    s->right_->file = std::move(*r);
  }
  return s;
}

Result<std::unique_ptr<StereoSource>> StereoSource::open_side_by_side(const std::string& spec,
                                                                      const StereoSourceOptions& options) {
  if (auto e = options.validate(); !e.empty()) return Error{"StereoSourceOptions: " + e};
  auto src = FrameSource::open(spec, options.source);
  if (!src) return Error{src.error()};
  const FrameSource& S = **src;
  if (S.width() % 2 != 0)
    return Error{spec + ": a side-by-side frame must have an even width (left eye | right eye); this one is " +
                 size_str(S.width(), S.height()) + ". Is it a side-by-side device? Otherwise give two cameras"};
  auto s = std::unique_ptr<StereoSource>(new StereoSource);
  s->options_ = options;
  s->side_by_side_ = true;
  s->live_ = is_live_spec(spec);
  s->width_ = S.width() / 2;
  s->height_ = S.height();
  s->fps_ = S.fps() > 0 ? S.fps() : 30;
  s->max_skew_s_ = 0;
  s->left_ = std::make_unique<Eye>();
  s->left_->spec = spec;
  s->left_->name = "side-by-side device";
  if (s->live_) {
    s->left_->thread = std::make_unique<CaptureThread>(std::move(*src), spec, options.source, options.left_capture);
    s->left_->thread->start();
    s->left_->opened_steady_s = steady_now_s();
  } else {
    s->left_->file = std::move(*src);
  }
  return s;
}

bool StereoSource::take(Eye& e, Frame& f, double timeout_s) {
  if (e.thread) return e.thread->wait_take(f, timeout_s);
  if (e.file_ended) return false;
  auto r = e.file->read(f);
  if (!r) {
    error_ = e.name + ": " + r.error();
    e.file_ended = true;
    return false;
  }
  if (!*r) e.file_ended = true;
  return *r;
}

bool StereoSource::eye_silent(const Eye& e, double now) const {
  if (e.has_pending) return false;
  if (e.ended()) return true;
  if (!e.thread) return false;  // a recording is read in step: never "late"
  const double last = std::max(e.thread->last_frame_steady_s(), e.opened_steady_s);
  return now - last > options_.single_after_s;
}

bool StereoSource::ended() const {
  if (side_by_side_) return left_->ended();
  return left_->ended() && right_->ended() && !left_->has_pending && !right_->has_pending;
}

void StereoSource::emit_pair(StereoFrame& out, Frame&& l, Frame&& r) {
  out = StereoFrame{};
  out.skew_s = live_ ? r.steady_s - l.steady_s : r.time_s - l.time_s;
  out.left = std::move(l);
  out.right = std::move(r);
  out.index = next_index_++;
  ++counts_.pairs;
  if (skews_ms_.size() < kMaxSkewSamples) skews_ms_.push_back(std::abs(out.skew_s) * 1e3);
  if (in_fallback_) {
    in_fallback_ = false;
    ++counts_.recoveries;
  }
}

void StereoSource::emit_single(StereoFrame& out, Frame&& f, bool left) {
  out = StereoFrame{};
  if (!in_fallback_) {
    in_fallback_ = true;
    ++counts_.fallbacks;
    const Eye& lost = left ? *right_ : *left_;
    if (lost.thread && lost.thread->last_frame_steady_s() > 0)
      counts_.fallback_latency_max_ms =
          std::max(counts_.fallback_latency_max_ms, (steady_now_s() - lost.thread->last_frame_steady_s()) * 1e3);
  }
  (left ? out.left : out.right) = std::move(f);
  (left ? counts_.left_only : counts_.right_only) += 1;
  out.index = next_index_++;
}

bool StereoSource::read(StereoFrame& out, double timeout_s) {
  if (side_by_side_) {
    Frame f;
    if (!take(*left_, f, timeout_s)) return false;
    const int w = f.image.cols / 2;
    // YUYV (a YUYV device, or a Motion JPEG one decoded to YUYV) splits on whole pixel
    // pairs only: eyes of odd width are converted to BGR first.
    if (f.image.type() == CV_8UC2 && w % 2 != 0) f.image = frame_bgr(f.image);
    Frame l = f, r = f;
    l.image = f.image(cv::Rect(0, 0, w, f.image.rows)).clone();
    r.image = f.image(cv::Rect(w, 0, w, f.image.rows)).clone();
    l.encoded = r.encoded = cv::Mat();  // the device's JPEG holds both eyes
    emit_pair(out, std::move(l), std::move(r));
    return true;
  }
  Eye& L = *left_;
  Eye& R = *right_;
  auto key = [&](const Frame& f) { return live_ ? f.steady_s : f.time_s; };
  auto store = [&](Eye& e, Frame&& f) {
    if (e.has_pending) ++(&e == &L ? counts_.unpaired_left : counts_.unpaired_right);
    e.pending = std::move(f);
    e.has_pending = true;
  };
  auto poll = [&](Eye& e) {
    if (!live_ && e.has_pending) return;  // a recording: one frame at a time
    Frame f;
    if (take(e, f, 0)) store(e, std::move(f));
  };
  const double deadline = steady_now_s() + timeout_s;
  for (;;) {
    poll(L);
    poll(R);
    if (!error_.empty()) return false;
    if (L.has_pending && R.has_pending) {
      const double d = key(R.pending) - key(L.pending);
      if (std::abs(d) <= max_skew_s_ + 1e-9) {
        L.has_pending = R.has_pending = false;
        emit_pair(out, std::move(L.pending), std::move(R.pending));
        return true;
      }
      // No partner for the older one: it is dropped, the newer waits for its own.
      Eye& older = d > 0 ? L : R;
      older.has_pending = false;
      ++(&older == &L ? counts_.unpaired_left : counts_.unpaired_right);
      continue;
    }
    const double now = steady_now_s();
    if (L.has_pending && eye_silent(R, now)) {
      L.has_pending = false;
      emit_single(out, std::move(L.pending), true);
      return true;
    }
    if (R.has_pending && eye_silent(L, now)) {
      R.has_pending = false;
      emit_single(out, std::move(R.pending), false);
      return true;
    }
    if (ended()) return false;
    if (!live_) continue;  // cannot happen (each eye has a frame or has ended); kept safe
    if (now >= deadline) return false;
    // Wait a little for the eye that has nothing yet (the other's frames wait in its slot).
    Eye& w = !L.has_pending ? L : R;
    Frame f;
    if (take(w, f, std::min(deadline - now, 0.004))) store(w, std::move(f));
  }
}

StereoCaptureStats StereoSource::stats() const {
  StereoCaptureStats s = counts_;
  s.skew_p50_ms = percentile(skews_ms_, 0.5);
  s.skew_p95_ms = percentile(skews_ms_, 0.95);
  s.skew_max_ms = skews_ms_.empty() ? 0 : *std::max_element(skews_ms_.begin(), skews_ms_.end());
  auto fill = [](const Eye* e, std::int64_t& src, std::int64_t& cons) {
    if (!e) return;
    if (e->thread) {
      src = e->thread->dropped_source();
      cons = e->thread->dropped_consumer();
    } else if (e->file) {
      src = e->file->dropped_total();
    }
  };
  fill(left_.get(), s.source_dropped_left, s.consumer_dropped_left);
  if (!side_by_side_) fill(right_.get(), s.source_dropped_right, s.consumer_dropped_right);
  return s;
}

std::string StereoSource::description() const {
  if (side_by_side_)
    return "side-by-side stereo " + left_->spec + " (" + size_str(width_, height_) + " per eye, " + num(fps_, 2) +
           " fps)";
  return "stereo pair left " + left_->spec + ", right " + right_->spec + " (" + size_str(width_, height_) +
         " each, " + num(fps_, 2) + " fps)";
}

std::string StereoSource::status() const {
  std::string s;
  const double now = steady_now_s();
  for (const Eye* e : {left_.get(), right_.get()}) {
    if (!e || !e->thread) continue;
    const double last = std::max(e->thread->last_frame_steady_s(), e->opened_steady_s);
    if (now - last > options_.single_after_s || e->thread->ended()) {
      if (!s.empty()) s += "; ";
      const std::string why = e->thread->status();
      s += e->name + " (" + e->spec + ") lost" + (why.empty() ? " (no frame for " + num((now - last) * 1e3, 0) + " ms)" : ": " + why);
    }
  }
  if (!error_.empty()) s += (s.empty() ? "" : "; ") + error_;
  return s;
}

}  // namespace dentar::ar
