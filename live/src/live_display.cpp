// dentar live's display loop (main thread): the window, the HUD and the stop
// conditions. See live_run.h.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <opencv2/imgcodecs.hpp>

#include "dentar/ar/frame_source.h"
#include "dentar/ar/note_label.h"
#include "dentar/haptics/engine.h"
#include "dentar/live/eye_output.h"
#include "dentar/live/hud_window.h"
#include "dentar/live/redraw_policy.h"
#include "dentar/session/frames_csv.h"
#include "dentar/session/recorder.h"
#include "dentar/volume/material.h"
#include "live_run.h"

namespace dentar::live {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::min<double>(v.size() - 1, std::ceil(q * (v.size() - 1))));
  return v[i];
}

double rss_mb() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, rss = 0;
  f >> pages >> rss;
  return static_cast<double>(rss) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
}

CpuSnapshot cpu_snapshot() {
  CpuSnapshot c;
  const double tick_ms = 1e3 / static_cast<double>(sysconf(_SC_CLK_TCK));
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  c.process_ms = (ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) * 1e3 + (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-3;
  std::error_code ec;
  for (const auto& d : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    std::ifstream fc(d.path() / "comm"), fs(d.path() / "stat");
    std::string name, stat;
    if (!std::getline(fc, name) || !std::getline(fs, stat)) continue;  // the thread ended meanwhile
    // stat: "tid (comm) state ..." with utime and stime the 14th and 15th fields; comm may hold spaces.
    const std::size_t close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    std::string field;
    double ut = 0, st = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) ut = std::atof(field.c_str());
      if (i == 15) st = std::atof(field.c_str());
    }
    c.threads.push_back({std::atol(d.path().filename().c_str()), name, (ut + st) * tick_ms});
  }
  return c;
}

std::map<std::string, double> cpu_per_name_ms(const CpuSnapshot& a, const CpuSnapshot& b) {
  std::map<std::string, double> out;
  for (const auto& t : b.threads) {
    double before = 0;
    for (const auto& u : a.threads)
      if (u.tid == t.tid) before = u.ms;
    out[t.name] += t.ms - before;
  }
  return out;
}

namespace {

double now_s() { return ar::steady_now_s(); }

class DisplayLoop {
 public:
  DisplayLoop(const LiveContext& c, LiveShared& sh, const DisplayInputs& in, LiveSummary& sum)
      : c_(c), sh_(sh), in_(in), sum_(sum), engine_(*c.run.engine()), gpu_display_(sh.gl_path.load()) {}

  DisplayFigures run() {
    fig_.t_start = now_s();
    fig_.stop_reason = "window closed";
    fps_t0_ = fig_.t_start;
    setup_output();
    if (const char* e = std::getenv("DENTAR_DISPLAY_PROFILE"); e != nullptr && std::string(e) == "1")
      c_.hw.set_profile(true);
    redraw_.idle_period_s = c_.o.idle_redraw_ms / 1e3;
    while (!stop_now()) frame();
    sum_.warp_grid_builds = c_.hw.output().warp_grid_builds();
    if (!sum_.display_texture.empty()) sum_.display_texture_scale = c_.hw.upload_scale();
    if (cpu_from_displayed_ >= 0 && fig_.displayed > cpu_from_displayed_) {  // session 19: CPU per frame shown
      const CpuSnapshot end = cpu_snapshot();
      const double n = static_cast<double>(fig_.displayed - cpu_from_displayed_);
      sum_.cpu_window_s = now_s() - cpu_from_s_;
      sum_.cpu_frames = fig_.displayed - cpu_from_displayed_;
      sum_.cpu_process_ms_per_frame = (end.process_ms - cpu_from_.process_ms) / n;
      for (const auto& [name, ms] : cpu_per_name_ms(cpu_from_, end)) sum_.cpu_threads_ms_per_frame[name] = ms / n;
    }
    return std::move(fig_);
  }

 private:
  // A stop condition met (fig_.stop_reason set).
  bool stop_now() {
    const LiveOptions& o = c_.o;
    if (c_.hw.should_close()) return true;
    const int sig = in_.signal ? in_.signal->load() : 0;
    if (sig != 0) return stop(sig == SIGINT ? "SIGINT" : "SIGTERM");
    if (o.seconds > 0 && now_s() - fig_.t_start >= o.seconds) return stop("time limit");
    if (in_.hand_end_s > 0 && static_cast<double>(engine_.stats().steps) / in_.rate_hz >= in_.hand_end_s + 1.0)
      return stop("the simulated hand finished the exercise");
    if (o.frames > 0 && fig_.displayed >= o.frames) return stop("frame limit");
    if (in_.lesson_end_s > 0 && engine_.snapshot().expert_time_s >= in_.lesson_end_s &&
        (!c_.lesson_pauses || c_.lesson_pauses->pausing() < 0))  // a pause point at the very end is held
      return stop("the lesson's recording ended");
    bool fresh_pending = false;
    {
      std::lock_guard<std::mutex> lock(sh_.shown_m);
      fresh_pending = sh_.shown_new;
    }
    if (in_.capture.ended() && !fresh_pending && sh_.processed.load() > 0 &&
        now_s() - in_.capture.last_frame_steady_s() > 0.5)
      return stop("footage ended");
    return false;
  }
  bool stop(const char* why) {
    fig_.stop_reason = why;
    return true;
  }

  // Takes the frame thread's newest frame, if any. new_slot: the GPU path's texture.
  bool take_shown(int& new_slot) {
    // Draw when a frame arrives; otherwise redraw the HUD at ~30 Hz (an
    // idle loop must not spin: under Xvfb there is no vsync to pace it).
    std::unique_lock<std::mutex> lock(sh_.shown_m);
    sh_.shown_cv.wait_for(lock, std::chrono::milliseconds(30), [&] { return sh_.shown_new; });
    if (!sh_.shown_new) return false;
    Shown& shown = sh_.shown;
    cv::swap(cur_.composite, shown.composite);
    cv::swap(cur_.composite_right, shown.composite_right);
    cv::swap(cur_.patch, shown.patch);
    cv::swap(cur_.patch_right, shown.patch_right);
    cur_.patch_rect = shown.patch_rect;
    cur_.patch_rect_right = shown.patch_rect_right;
    cur_.raw_right = shown.raw_right;
    cur_.gpu = shown.gpu;
    if (cur_.gpu) new_slot = sh_.ring->take();
    cur_.raw = shown.raw;
    cur_.index = shown.index;
    cur_.steady_s = shown.steady_s;
    cur_.handed_s = shown.handed_s;
    taken_s_ = now_s();
    cur_.rec = shown.rec;
    cur_.error = shown.error;
    cur_.note.swap(shown.note);
    cur_.switches.append(shown.switches);  // kept until drawn (figures_after_swap)
    shown.switches.clear();
    shown.switches.reset_dropped();
    cur_.unpaired_from_s = shown.unpaired_from_s;
    sh_.shown_new = false;
    return true;
  }

  // Issue 28: the headset's side-by-side view and the loupe (eye_output.h).
  void setup_output() {
    const LiveOptions& o = c_.o;
    cam_ = c_.st.calibration.camera;
    if (cam_.width != c_.W || cam_.height != c_.H) {  // --scale-calib: the pipeline's scaling
      const double sx = double(c_.W) / cam_.width, sy = double(c_.H) / cam_.height;
      cam_.fx *= sx, cam_.fy *= sy;
      cam_.cx = (cam_.cx + 0.5) * sx - 0.5, cam_.cy = (cam_.cy + 0.5) * sy - 0.5;
      cam_.width = c_.W, cam_.height = c_.H;
    }
    // A stereo rig: the right eye's camera and where it sees from (its own composite, loupe).
    stereo_ = c_.popt.stereo && c_.st.stereo.present;
    if (stereo_) {
      cam_right_ = c_.st.stereo.camera_right;
      if (cam_right_.width != c_.W || cam_right_.height != c_.H) {  // as the left eye's
        const double sx = double(c_.W) / cam_right_.width, sy = double(c_.H) / cam_right_.height;
        cam_right_.fx *= sx, cam_right_.fy *= sy;
        cam_right_.cx = (cam_right_.cx + 0.5) * sx - 0.5, cam_right_.cy = (cam_right_.cy + 0.5) * sy - 0.5;
        cam_right_.width = c_.W, cam_right_.height = c_.H;
      }
      T_camr_rig_ = c_.st.stereo.T_caml_camr.inverse();
    }
    const volume::VoxelVolume& vol = c_.run.volume();
    tooth_centre_ = vol.origin() + vol.spacing().cwiseProduct((vol.dims() - Eigen::Vector3i::Ones()).cast<double>() / 2);
    if (o.output == "mono" && o.loupe == 0) return;  // the window as before
    WarpPass pass = WarpPass::kExact;
    parse_warp_pass(o.warp_pass, pass);  // validated with the options
    auto out = o.output == "sbs" ? make_sbs_output(c_.hw.gles_egl(), *o.headset, cam_, stereo_, stereo_ ? &cam_right_ : nullptr,
                                                   pass, o.warp_cell_px)
                                 : make_mono_output(c_.hw.gles_egl(), cam_);
    if (!out) {
      c_.say("output " + o.output + ": " + out.error() + "; the mono window instead");
      sum_.warnings.push_back("output " + o.output + " unavailable: " + out.error());
      return;
    }
    loupe_.mag = o.loupe;
    loupe_.inset = o.loupe_view == "inset";
    (*out)->set_loupe(loupe_);
    c_.hw.set_output(std::move(*out));
    if (o.output == "sbs") {  // the pre-warp pass asked for (a loupe inset draws the whole viewport: full)
      sum_.warp_pass = warp_pass_name(pass);
      sum_.warp_cell_px = o.warp_cell_px;
      sum_.display_texture = o.display_texture;
      sum_.display_half_convert = o.display_half_convert;
      choose_texture_scale();
    }
    c_.say(o.output == "sbs" ? "output: side-by-side for headset \"" + o.headset->name + "\" (" +
                                   std::to_string(o.headset->panel_w) + "x" + std::to_string(o.headset->panel_h) +
                                   (stereo_ ? "), a stereo pair: each eye its own camera and composite" : ", one camera") +
                                   "; keys: W pre-warp on/off, L loupe off/inset/full"
                             : std::string("output: mono window with the loupe; key L: loupe off/inset/full"));
  }

  // Issue 28 session 22 (--display-texture): the headset view's camera textures at half size
  // when asked, or (auto) when the loupe is off and a half-size texel still covers at most one
  // window pixel at each lens centre. There the panel is densest: the pre-warp shrinks the
  // picture away from the centre, so elsewhere a window pixel covers more camera pixels, never
  // fewer. The loupe magnifies the camera's full resolution: full size while it is on.
  void choose_texture_scale() {
    const LiveOptions& o = c_.o;
    if (o.output != "sbs" || std::string(c_.hw.output().kind()) != "sbs" || gpu_display_) return;
    int scale = 1;
    if (o.display_texture == "half") {
      scale = 2;
    } else if (o.display_texture == "auto" && loupe_.mag <= 0) {
      float rects[2][4];
      const int n = c_.hw.eye_rects(rects);
      const double c0[2] = {0, 0};
      double ratio = 1e9;  // camera px per window px at the lens centre, the smallest over the eyes and axes
      for (int e = 0; e < 2 && n == 2; ++e) {
        const EyeMapping m = make_eye_mapping(*o.headset, e, e == 1 && stereo_ ? cam_right_ : cam_, stereo_, {}, c0, true);
        const double win_per_panel = rects[e][2] / std::max(1, m.vp[2]);
        for (int a = 0; a < 2; ++a) ratio = std::min(ratio, m.f_cam[a] / (m.f_eye[a] * win_per_panel));
      }
      if (n == 2 && ratio >= 2.0) scale = 2;
      texture_ratio_ = n == 2 ? ratio : 0;
      sum_.display_texture_ratio = texture_ratio_;
    }
    c_.hw.set_upload_scale(scale);
    c_.hw.set_half_direct(o.display_half_convert == "direct");
  }

  // The loupe's centre from this frame's mannequin pose (headset.h LoupeCentre);
  // keys: W toggles the pre-warp, L cycles the loupe off / inset / full.
  void update_output(bool fresh, const std::vector<int>& keys) {
    for (const int key : keys) {
      if (key == GLFW_KEY_W) {
        prewarp_ = !prewarp_;
        c_.hw.output().set_prewarp(prewarp_);
      } else if (key == GLFW_KEY_L) {
        const double mag = c_.o.loupe > 0 ? c_.o.loupe : 3.0;
        if (loupe_.mag == 0) loupe_.mag = mag, loupe_.inset = true;
        else if (loupe_.inset) loupe_.inset = false;
        else loupe_.mag = 0;
        if (std::string(c_.hw.output().kind()) == "mono" && c_.o.output == "mono" && c_.o.loupe == 0 && !mono_loupe_) {
          // The mono window made without a loupe: one with the loupe's pass.
          if (auto out = make_mono_output(c_.hw.gles_egl(), cam_)) c_.hw.set_output(std::move(*out)), mono_loupe_ = true;
        }
        c_.hw.output().set_loupe(loupe_);
        choose_texture_scale();
      }
    }
    if (!fresh) return;
    double u = 0, v = 0;
    // The left camera lost (two cameras): the frame shown is the right eye's, seen from there.
    const bool right_alone = stereo_ && cur_.rec.eyes == ar::FrameRecord::kEyesRight;
    const Eigen::Isometry3d T_main_rig = right_alone ? T_camr_rig_ : Eigen::Isometry3d::Identity();
    const bool ok = cur_.rec.man_state != 2 &&
                    project_point(right_alone ? cam_right_ : cam_,
                                  T_main_rig * cur_.rec.T_cam_man * c_.st.calibration.T_man_tooth, tooth_centre_, u, v);
    if (!loupe_c_.initialised()) loupe_c_.reset(cam_.cx, cam_.cy);
    loupe_c_.update(ok, u, v);
    if (!stereo_) {
      c_.hw.set_loupe_centre(loupe_c_.centre(), loupe_c_.centre());
      return;
    }
    // A stereo pair: each eye's loupe centred on the tooth as that eye sees it.
    const bool ok_r = cur_.rec.man_state != 2 &&
                      project_point(cam_right_, T_camr_rig_ * cur_.rec.T_cam_man * c_.st.calibration.T_man_tooth,
                                    tooth_centre_, u, v);
    if (!loupe_cr_.initialised()) loupe_cr_.reset(cam_right_.cx, cam_right_.cy);
    loupe_cr_.update(ok_r, u, v);
    c_.hw.set_loupe_centre(loupe_c_.centre(), loupe_cr_.centre());
  }

  void frame() {
    int new_slot = -1;
    const bool fresh = take_shown(new_slot);
    DisplayProfile& prof = c_.hw.profile();
    if (prof.on) prof.clear();
    const double cpu0 = prof.on ? thread_cpu_ms() : 0;
    if (const haptics::HapticSnapshot snap = engine_.snapshot(); snap.mode != 0) {
      // A lesson: how closely the student follows the expert.
      ++fig_.passes;
      if (snap.expert_time_s >= 0.5) fig_.follow_m.push_back(snap.follow_error_m);
      fig_.passes_expert_waiting += snap.expert_waiting ? 1 : 0;
      reach_notes(snap.expert_time_s);
      prev_pass_expert_s_ = snap.expert_time_s;
    }
    HudWindow& hw = c_.hw;
    hw.poll();
    // Test hook: scripted key presses at the first frame shown at or after their frame.
    for (auto it = keys_.begin(); fresh && it != keys_.end();)
      if (it->first <= cur_.index) hw.inject_key(it->second), it = keys_.erase(it);
      else ++it;
    const std::vector<int> keys = hw.take_presses();
    for (const int key : keys) {
      if (key == GLFW_KEY_ESCAPE) hw.request_close();
      // Enter ends a lesson's pause point (the pen stylus has no pause button).
      if ((key == GLFW_KEY_ENTER || key == GLFW_KEY_KP_ENTER) && c_.lesson_pauses) c_.lesson_pauses->request_resume();
    }
    update_output(fresh, keys);
    c_.key_pedal.set_pressed(hw.held(GLFW_KEY_SPACE));
    // The camera went quiet: show the video without the overlay within 200 ms.
    // One read of the capture time per check: a frame may land before the
    // swap, and the figure below must be about the silence this check saw.
    // Two cameras: the overlay stays while either delivers (the other eye's single view).
    double last_frame_s = in_.capture.last_frame_steady_s();
    if (const ar::CaptureThread* r = sh_.capture_right.load())
      last_frame_s = std::max(last_frame_s, r->last_frame_steady_s());
    const double age = cur_.index >= 0 ? now_s() - last_frame_s : 0;
    const bool stalled = cur_.index >= 0 && age > 0.15;
    if (stalled && stall_seen_at_ < 0) stall_seen_at_ = now_s();
    if (!stalled) stall_seen_at_ = -1;
    // Issue 28 session 19 (redraw_policy.h): a wake without a new frame redraws only what must
    // change at once (the stall state, a key) or the HUD at its idle rate; the pre-warp over a
    // frame already shown is not drawn again.
    if (!redraw_due(redraw_, fresh, stalled != drawn_stalled_, !keys.empty(), now_s() - last_swap_s_)) {
      ++fig_.idle_skipped;
      prev_check_age_s_ = age;
      return;
    }
    if (!fresh) ++fig_.idle_draws;
    drawn_stalled_ = stalled;
    const cv::Mat& img = stalled ? cur_.raw : cur_.composite;
    if (fresh && new_slot >= 0) {
      // The composite on the GPU: wait for its fence, then draw from it.
      sh_.ring->wait_ready(new_slot);
      const ar::GlFrameTarget t = sh_.ring->target(new_slot);
      hw.set_frame(t.video_texture, t.overlay_texture, sh_.ring->region(new_slot));
      shown_slot_ = new_slot;
    }
    if (!img.empty() && (fresh || stalled)) {
      if (stalled) hw.set_video(img);
      else hw.set_video(img, cur_.patch, cur_.patch_rect);
      shown_slot_ = -1;
    }
    // The right eye of a stereo pair (the headset's view): its own composite, or its raw
    // frame while the camera is silent; none (an eye missing, or mono): both eyes see `img`.
    if (stereo_ && (fresh || stalled)) {
      if (stalled) hw.set_video_right(cur_.raw_right);
      else hw.set_video_right(cur_.composite_right, cur_.patch_right, cur_.patch_rect_right);
    }
    hw.begin_frame();
    // The GPU path's composite never reaches the CPU: the note's label is drawn over it here.
    // Its layout is the mono letterbox; a headset view shows the CPU composite's label only.
    const bool mono = std::string(hw.output().kind()) == "mono";
    if (cur_.gpu && !stalled && mono && cur_.rec.note_anchored && !cur_.rec.note_drawn && !cur_.note.empty())
      draw_note_label();
    if (c_.o.hud) draw_hud(stalled, age);
    // Test hook: the window's pixels for frame N (read before the swap).
    const auto shot = fresh ? std::find_if(shots_.begin(), shots_.end(), [&](const auto& x) { return x.first == cur_.index; })
                            : shots_.end();
    const cv::Mat px = hw.end_frame(shot != shots_.end());
    last_swap_s_ = now_s();
    if (shown_slot_ >= 0) sh_.ring->release(shown_slot_);  // the producer may draw into it once this completes
    if (shot != shots_.end()) {
      cv::imwrite(shot->second, px);
      shots_.erase(shot);
    }
    if (prof.on && fresh && cur_.index != last_index_) {
      double parts = 0, parts_cpu = 0;
      for (int p = 0; p < DisplayProfile::kParts; ++p) {
        if (prof.wall_ms[p] < 0) continue;
        fig_.display_parts_ms[std::string("disp_") + DisplayProfile::name(p)].add(prof.wall_ms[p]);
        fig_.display_parts_ms[std::string("disp_") + DisplayProfile::name(p) + "_cpu"].add(prof.cpu_ms[p]);
        parts += prof.wall_ms[p];
        parts_cpu += prof.cpu_ms[p];
      }
      const double cpu = thread_cpu_ms() - cpu0;
      fig_.display_parts_ms["disp_total_cpu"].add(cpu);
      fig_.display_parts_ms["disp_other_cpu"].add(std::max(0.0, cpu - parts_cpu));
      fig_.display_parts_ms["disp_other"].add(std::max(0.0, (now_s() - taken_s_) * 1e3 - parts));
    }
    figures_after_swap(fresh, stalled, age, last_frame_s);
  }

  // A lesson's note beside the tooth over the GPU path's composite: the frame pipeline's
  // layout (ar/note_label.h) in window coordinates, drawn with ImGui's font.
  void draw_note_label() {
    HudWindow& hw = c_.hw;
    const auto& cam = c_.st.calibration.camera;
    const ar::NoteLabelLayout l = ar::layout_note_label(cur_.note, cur_.rec.note_anchor_px, cv::Size(cam.width, cam.height));
    auto at = [&](double x, double y) {
      ImVec2 p;
      hw.image_to_window(x, y, p.x, p.y);
      return p;
    };
    auto col = [](const cv::Scalar& c) {
      return IM_COL32(static_cast<int>(c[2]), static_cast<int>(c[1]), static_cast<int>(c[0]), 255);
    };
    const ar::NoteLabelStyle st;
    const ImVec2 lo = at(0, 0), hi = at(cam.width, cam.height);
    const float sc = cam.width > 0 ? (hi.x - lo.x) / static_cast<float>(cam.width) : 1.0f;  // window px per image px
    // Hershey simplex at scale 1 is ~30 px a line: the same line height in ImGui's font.
    const float fs = std::max(8.0f, static_cast<float>(l.font_scale) * 26.0f * sc);
    const float pad = 6.0f * sc * static_cast<float>(l.font_scale) / 0.6f;
    ImFont* font = ImGui::GetFont();
    float w = 0;
    for (const std::string& s : l.lines) w = std::max(w, font->CalcTextSizeA(fs, FLT_MAX, 0, s.c_str()).x);
    const ImVec2 size(w + 2 * pad, static_cast<float>(l.lines.size()) * fs * 1.15f + 2 * pad);
    ImVec2 b0 = at(l.box.x, l.box.y);
    b0.x = std::clamp(b0.x, lo.x, std::max(lo.x, hi.x - size.x));
    b0.y = std::clamp(b0.y, lo.y, std::max(lo.y, hi.y - size.y));
    const ImVec2 b1(b0.x + size.x, b0.y + size.y);
    const ImVec2 a = at(l.anchor.x, l.anchor.y);
    const ImVec2 e(std::clamp(a.x, b0.x, b1.x), std::clamp(a.y, b0.y, b1.y));
    ImDrawList* dl = ImGui::GetBackgroundDrawList();
    dl->AddLine(a, e, col(st.border), std::max(1.0f, 2.0f * sc * static_cast<float>(l.thickness)));
    dl->AddCircleFilled(a, (2.0f * static_cast<float>(l.thickness) + 1.0f) * sc, col(st.border));
    dl->AddRectFilled(b0, b1, col(st.background));
    dl->AddRect(b0, b1, col(st.border));
    for (std::size_t i = 0; i < l.lines.size(); ++i)
      dl->AddText(font, fs, ImVec2(b0.x + pad, b0.y + pad + static_cast<float>(i) * fs * 1.15f), col(st.text),
                  l.lines[i].c_str());
  }

  // The lesson's text annotations the expert's clock reached: on the HUD from then on for
  // kNoteShowS (and through their pause), logged in the recording's log.
  static constexpr double kNoteShowS = 5.0;
  void reach_notes(double expert_s) {
    const session::LessonClock* l = c_.run.lesson();
    if (!l || !c_.o.hud) return;
    const auto& ann = l->lesson().annotations;
    for (; next_note_ < ann.size() && ann[next_note_].time_s <= expert_s; ++next_note_) {
      if (ann[next_note_].text.empty()) continue;
      fig_.notes.push_back({static_cast<int>(next_note_), expert_s, prev_pass_expert_s_, now_s() - fig_.t_start});
      if (session::Recorder* rec = c_.run.recorder()) {
        char b[96];
        std::snprintf(b, sizeof b, "lesson note at %.2f s (expert's clock %.2f s) on the HUD: ", ann[next_note_].time_s,
                      expert_s);
        rec->log(b + ann[next_note_].text);
      }
    }
  }

  // The lesson's lines: a pause point holding the expert's clock, and the notes on show.
  void draw_lesson_lines(const ImVec4& hi) {
    const session::LessonClock* l = c_.run.lesson();
    if (!l) return;
    const auto& ann = l->lesson().annotations;
    const int p = c_.lesson_pauses ? c_.lesson_pauses->pausing() : -1;
    if (p >= 0) {
      if (c_.pen)
        ImGui::TextColored(hi, "PAUSED by the lesson: the expert resumes in %.1f s, or press Enter",
                           c_.lesson_pauses->pause_left_s());
      else
        ImGui::TextColored(hi, "PAUSED by the lesson: the expert resumes in %.1f s, or press and release the stylus's "
                           "pause button (second button) or Enter", c_.lesson_pauses->pause_left_s());
    } else if (c_.lesson_pauses && c_.lesson_pauses->student_holding()) {
      ImGui::TextColored(hi, "PAUSED by you: the expert waits while the stylus's pause button (second button) is down");
    }
    const double t = now_s() - fig_.t_start;
    for (const DisplayFigures::Note& n : fig_.notes)
      if (t - n.run_s < kNoteShowS || n.annotation == p)
        ImGui::TextColored(hi, "lesson (%.1f s): %s", ann[static_cast<std::size_t>(n.annotation)].time_s,
                           ann[static_cast<std::size_t>(n.annotation)].text.c_str());
  }

  void figures_after_swap(bool fresh, bool stalled, double age, double last_frame_s) {
    const double t_swap = now_s();
    if (fresh && cur_.index != last_index_ && cur_.unpaired_from_s > 0 && cur_.unpaired_from_s != unpaired_from_s_) {
      unpaired_from_s_ = cur_.unpaired_from_s;  // the first frame without the right eye since its last frame
      unpaired_swap_s_ = t_swap;
      unpaired_frame_ms_ = (t_swap - cur_.steady_s) * 1e3;
    }
    if (fresh && cur_.index != last_index_) {
      // Cameras lost or back (two cameras; every one queued since the last frame taken): from
      // its capture time to the swap of the first frame drawn in the new mode (the right
      // camera lost: the first frame without it).
      for (int i = 0; i < cur_.switches.size(); ++i) {
        const EyeSwitchEvent& sw = cur_.switches[i];
        const int e = sw.eyes;
        const bool earlier = sw.kind == EyeSwitchKind::kRightLost && unpaired_from_s_ == sw.from_s;
        sum_.eye_switches.push_back({eye_switch_what(sw.kind, c_.o.camera, c_.o.camera_right),
                                     e == ar::FrameRecord::kEyesBoth   ? "both"
                                     : e == ar::FrameRecord::kEyesLeft ? "left"
                                     : e == ar::FrameRecord::kEyesRight ? "right"
                                                                        : "none",  // kEyesNone: neither camera
                                     sw.from_s <= 0 ? -1.0  // no capture time to time it from: listed, not timed
                                                    : ((earlier ? unpaired_swap_s_ : t_swap) - sw.from_s) * 1e3,
                                     earlier ? unpaired_frame_ms_ : (t_swap - cur_.steady_s) * 1e3});
      }
      sum_.eye_switches_dropped += cur_.switches.dropped();
      cur_.switches.clear();
      cur_.switches.reset_dropped();
    }
    if (fresh && cur_.index != last_index_) {
      fig_.latency_ms.push_back((t_swap - cur_.steady_s) * 1e3);
      fig_.to_display_ms.add((taken_s_ - cur_.handed_s) * 1e3);
      fig_.display_ms.add((t_swap - taken_s_) * 1e3);
      last_index_ = cur_.index;
      ++fig_.displayed;
      ++fps_n_;
    }
    if (stalled && stall_seen_at_ > 0 && sum_.overlay_hidden_ms_after_stall < 0) {
      sum_.overlay_hidden_ms_after_stall = static_cast<int>(std::lround((t_swap - last_frame_s) * 1e3));
      sum_.stall_previous_check_ms = static_cast<int>(std::lround(prev_check_age_s_ * 1e3));
    }
    prev_check_age_s_ = age;
    if (sum_.rss_warm_mb == 0 && t_swap - fig_.t_start >= 10.0) sum_.rss_warm_mb = rss_mb();
    if (cpu_from_displayed_ < 0 && t_swap - fig_.t_start >= kCpuWarmS) {  // the CPU figures count from here
      cpu_from_ = cpu_snapshot();
      cpu_from_s_ = t_swap;
      cpu_from_displayed_ = fig_.displayed;
    }
    if (t_swap - fps_t0_ >= 1.0) {
      if (t_swap - fig_.t_start >= 60.0) {
        const double r = rss_mb();
        if (sum_.rss_60s_mb == 0) sum_.rss_60s_mb = r;
        sum_.rss_max_after_60s_mb = std::max(sum_.rss_max_after_60s_mb, r);
      }
      fps_now_ = fps_n_ / (t_swap - fps_t0_);
      fps_t0_ = t_swap;
      fps_n_ = 0;
    }
  }

  // The HUD: in the mono window once, at its top-left corner; in the headset's side-by-side
  // view once inside each eye's viewport (HudWindow::eye_rects), 12 % in from the viewport's
  // top-left corner toward the lens and at most 76 % of it wide and high (the font scaled
  // down to fit, at most to 0.6), so each eye sees
  // the whole HUD at the same place of its view (drawn after the lens pre-warp: not warped).
  void draw_hud(bool stalled, double age) {
    float rects[2][4];
    const int n = std::string(c_.hw.output().kind()) == "sbs" ? c_.hw.eye_rects(rects) : 0;
    if (n < 2) {
      ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
      ImGui::SetNextWindowBgAlpha(0.6f);
      ImGui::Begin("DentAR", nullptr, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove);
      draw_hud_lines(stalled, age);
      ImGui::End();
      return;
    }
    for (int e = 0; e < 2; ++e) {
      const float* r = rects[e];
      ImGui::SetNextWindowPos(ImVec2(r[0] + 0.12f * r[2], r[1] + 0.12f * r[3]), ImGuiCond_Always);
      ImGui::SetNextWindowSizeConstraints(ImVec2(0, 0), ImVec2(0.76f * r[2], 0.76f * r[3]));
      ImGui::SetNextWindowBgAlpha(0.6f);
      ImGui::Begin(e == 0 ? "DentAR##left eye" : "DentAR##right eye", nullptr,
                   ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoTitleBar |
                       ImGuiWindowFlags_NoScrollbar);
      // The HUD's longest lines are ~600 px at scale 1: scaled to fit the eye's viewport.
      ImGui::SetWindowFontScale(std::clamp(0.76f * r[2] / 620.0f, 0.6f, 1.0f));
      draw_hud_lines(stalled, age);
      ImGui::End();
    }
  }

  void draw_hud_lines(bool stalled, double age) {
    const ar::FrameRecord& r = cur_.rec;
    const haptics::HapticSnapshot snap = engine_.snapshot();
    PenDevice* pen = c_.pen;
    const ImVec4 col[] = {ImVec4(0.3f, 1, 0.3f, 1), ImVec4(1, 0.85f, 0.2f, 1), ImVec4(1, 0.3f, 0.3f, 1)};
    {
      // ok green, note grey-blue (not an alarm), warning yellow, instructor needed red.
      const ImVec4 health_col[] = {col[0], ImVec4(0.75f, 0.82f, 0.95f, 1), col[1], col[2]};
      const StationHealth h = c_.health.health();
      ImGui::TextColored(health_col[static_cast<int>(h.worst())], "%s", h.headline().c_str());
    }
    ImGui::TextColored(col[r.man_state], "mannequin: %s", session::state_name(r.man_state));
    ImGui::SameLine();
    ImGui::TextColored(col[r.mir_state], "  mirror: %s", session::state_name(r.mir_state));
    if (pen) {
      ImGui::SameLine();
      ImGui::TextColored(col[r.pen_state], "  pen: %s", session::state_name(r.pen_state));
    }
    const double f = std::sqrt(snap.force_dev_N[0] * snap.force_dev_N[0] + snap.force_dev_N[1] * snap.force_dev_N[1] +
                               snap.force_dev_N[2] * snap.force_dev_N[2]);
    const double fmax = c_.device.limits().max_force_N;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f N", f);
    ImGui::Text("force");
    ImGui::SameLine();
    ImGui::ProgressBar(static_cast<float>(std::min(1.0, f / fmax)), ImVec2(200, 0), buf);
    ImGui::TextUnformatted(hud_drill_line(snap.pedal, snap.in_contact, c_.pedal.status(), c_.pedal.pressed(),
                                          c_.pedal_from_device, c_.o.stylus)
                               .c_str());
    if (snap.mode != 0)
      ImGui::Text("lesson: mode %d   expert %.1f s%s   following error %.1f mm", static_cast<int>(snap.mode),
                  snap.expert_time_s, snap.expert_waiting ? " (waiting for you)" : "", snap.follow_error_m * 1e3);
    if (snap.mode != 0) draw_lesson_lines(ImVec4(0.45f, 0.85f, 1, 1));
    if (const std::string ds = c_.device.status(); !ds.empty()) ImGui::TextColored(col[1], "device: %s", ds.c_str());
    const std::string& sound_line = in_.sound_line;
    if (!sound_line.empty()) {
      if (sound_line == "sound: no device (silent)") ImGui::TextColored(col[1], "%s", sound_line.c_str());
      else ImGui::TextUnformatted(sound_line.c_str());
    }
    ImGui::Text("removed mm3: enamel %.2f  dentin %.2f  pulp %.2f",
                snap.removed_mm3[static_cast<int>(volume::Material::kEnamel)],
                snap.removed_mm3[static_cast<int>(volume::Material::kDentin)],
                snap.removed_mm3[static_cast<int>(volume::Material::kPulp)]);
    ImGui::Text("%.1f fps  latency %.0f ms  (display %s)", fps_now_, fig_.latency_ms.empty() ? 0.0 : fig_.latency_ms.back(),
                gpu_display_ ? "gl" : "cpu");
    if (stalled)
      ImGui::TextColored(col[2], "camera: no frame for %.0f ms, overlay hidden%s", age * 1e3,
                         in_.capture.status().empty() ? "" : (" (" + in_.capture.status() + ")").c_str());
    if (!stalled && !c_.o.camera_right.empty() && (r.eyes == ar::FrameRecord::kEyesLeft || r.eyes == ar::FrameRecord::kEyesRight)) {
      const bool left_lost = r.eyes == ar::FrameRecord::kEyesRight;
      ImGui::TextColored(col[1], "camera lost: %s eye (%s): single view from the %s eye, no stereo depth",
                         left_lost ? "left" : "right", (left_lost ? c_.o.camera : c_.o.camera_right).c_str(),
                         left_lost ? "right" : "left");
    }
    if (!cur_.error.empty()) ImGui::TextColored(col[2], "pipeline: %s", cur_.error.c_str());
    if (snap.watchdog) ImGui::TextColored(col[2], "haptics: watchdog: zero force");
    if (snap.fault) ImGui::TextColored(col[2], "haptics: device fault: zero force%s", pen ? " (pen not seen)" : "");
    if (snap.pulp_exposed) ImGui::TextColored(col[2], "PULP EXPOSED");
    if (pen) ImGui::TextColored(col[1], "pen mode: no force on the hand; space bar = pedal");
    if (!in_.rt_ok) ImGui::TextColored(col[1], "haptics not real-time: %s", in_.grant.c_str());
    if (!stalled && cur_.index >= 0 && now_s() - cur_.steady_s > 0.5)
      ImGui::TextColored(col[2], "frame pipeline stalled: no composite for %.0f ms", (now_s() - cur_.steady_s) * 1e3);
  }

  const LiveContext& c_;
  LiveShared& sh_;
  const DisplayInputs& in_;
  LiveSummary& sum_;
  haptics::Engine& engine_;
  const bool gpu_display_;
  DisplayFigures fig_;
  Shown cur_;
  std::vector<std::pair<std::int64_t, std::string>> shots_ = c_.o.screenshots;
  std::vector<std::pair<std::int64_t, int>> keys_ = c_.o.inject_keys;
  std::int64_t last_index_ = -1;
  double prev_pass_expert_s_ = -1;  // the expert's clock at the previous pass (a lesson; -1 before the first)
  double stall_seen_at_ = -1;
  // The summary's CPU per frame shown (session 19): from the first swap kCpuWarmS after the
  // start (set-up and the first tag discovery left out) to the end.
  static constexpr double kCpuWarmS = 5.0;
  CpuSnapshot cpu_from_;
  double cpu_from_s_ = 0;
  std::int64_t cpu_from_displayed_ = -1;
  RedrawPolicy redraw_;           // when a wake without a new frame redraws (redraw_policy.h)
  bool drawn_stalled_ = false;    // the stall state of the last frame drawn
  double last_swap_s_ = -1e9;     // the last swap (steady s)
  double prev_check_age_s_ = 0;  // the camera's silence at the previous window check, s
  double taken_s_ = 0;           // when the shown frame was taken from the frame thread (steady s)
  double fps_t0_ = 0, fps_now_ = 0;
  int fps_n_ = 0;
  std::size_t next_note_ = 0;  // the lesson's next annotation not yet reached
  int shown_slot_ = -1;  // GPU path: the ring texture the window draws from, or -1
  // Two cameras: the first frame drawn without the right eye since its last frame (Shown::unpaired_from_s).
  double unpaired_from_s_ = 0, unpaired_swap_s_ = 0, unpaired_frame_ms_ = 0;
  calibration::CameraIntrinsics cam_;  // of the frames' size
  Eigen::Vector3d tooth_centre_ = Eigen::Vector3d::Zero();  // tooth frame, m
  LoupeView loupe_{};
  LoupeCentre loupe_c_, loupe_cr_;  // the loupe's centre per eye (loupe_cr_: a stereo pair's right eye)
  bool prewarp_ = true, mono_loupe_ = false;
  double texture_ratio_ = 0;  // camera px per window px at the lens centre (choose_texture_scale; 0 not computed)
  bool stereo_ = false;  // a stereo rig: the right eye gets its own composite in the headset's view
  calibration::CameraIntrinsics cam_right_;  // the rig's right eye (stereo_)
  Eigen::Isometry3d T_camr_rig_ = Eigen::Isometry3d::Identity();
};

}  // namespace

DisplayFigures display_loop(const LiveContext& c, LiveShared& sh, const DisplayInputs& in, LiveSummary& sum) {
  return DisplayLoop(c, sh, in, sum).run();
}

}  // namespace dentar::live
