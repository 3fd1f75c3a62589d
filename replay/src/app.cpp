// See app.h.
#include "dentar/replay/app.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cctype>
#include <cstdlib>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dentar/ar/egl_context.h"
#include "dentar/replay/cut_player.h"
#include "dentar/replay/recording.h"
#include "dentar/replay/step_align.h"
#include "dentar/replay/view.h"
#include "window.h"

namespace dentar::replay {
namespace {

using Clock = std::chrono::steady_clock;

std::string fmt(double v, int prec = 1) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(prec);
  s << v;
  return s.str();
}

// One recording being played: its data, its cut, where the view shows it.
struct Side {
  Recording rec;
  std::unique_ptr<CutPlayer> player;
};

// Everything both the window and the headless render draw.
struct Replay {
  ReplayOptions opt;
  Side a;
  std::unique_ptr<Side> b;  // --against
  std::optional<TimeWarp> warp;
  double align_ms = 0;
  OrbitCamera cam, home;
  MaterialAlphas alphas;
  float ghost_alpha = 0.35f;
  bool superimpose = false;
  double t_s = 0;
  // Views: one (a alone or superimposed) or two side by side.
  std::unique_ptr<SceneView> view_a, view_b;
  int split_w = 0;  // side by side: the width of a's view (b's takes the rest)
  unsigned plot_a = 0, plot_b = 0;  // the force plots as textures (window only)
  cv::Mat frame, part;

  double b_time(double ta) const { return warp ? warp->b_at(ta) : ta; }
};

// The views cover the area the HUD leaves free: x from kPanelWidth, y above the timeline.
// a's view (all of it, or its left half), b's (the right half).
calibration::CameraIntrinsics view_k(const Replay& r, bool right) {
  const int W = r.opt.width - kPanelWidth, H = r.opt.height - kTimelineHeight;
  const double fov = r.cam.fov_y_rad;
  if (!r.b || r.superimpose) return view_intrinsics(W, H, 0.5 * W, 0.5 * H, fov);
  const int w = right ? W - r.split_w : r.split_w;
  return view_intrinsics(w, H, 0.5 * w, 0.5 * H, fov);
}

Status make_views(Replay& r) {
  r.view_a.reset();
  r.view_b.reset();
  auto va = SceneView::create(view_k(r, false), r.a.player->bur(), r.opt.play_scale, r.opt.play_lod_voxels);
  if (!va) return Error{va.error()};
  r.view_a = std::move(va).value();
  if (r.b && !r.superimpose) {
    auto vb = SceneView::create(view_k(r, true), r.b->player->bur(), r.opt.play_scale, r.opt.play_lod_voxels);
    if (!vb) return Error{vb.error()};
    r.view_b = std::move(vb).value();
  }
  return {};
}

Status seek(Replay& r, double t) {
  r.t_s = std::clamp(t, 0.0, r.a.rec.duration_s);
  if (auto s = r.a.player->seek(r.t_s); !s) return Error{s.error()};
  if (r.b)
    if (auto s = r.b->player->seek(r.b_time(r.t_s)); !s) return Error{s.error()};
  return {};
}

SceneView::Tooth tooth_of(const Side& s) {
  SceneView::Tooth t;
  t.surface = &s.player->surface();
  t.T_tooth_tip = s.player->T_tooth_tip();
  t.bur_cutting = s.player->pedal();
  return t;
}

// Renders the current state into the views' framebuffers (reduced: at ReplayOptions::play_scale).
void render_views(Replay& r, bool reduced = false) {
  const SceneView::Tooth ta = tooth_of(r.a);
  if (!r.b) {
    r.view_a->render(r.cam, ta, r.alphas, nullptr, 0.35f, reduced);
    return;
  }
  const SceneView::Tooth tb = tooth_of(*r.b);
  if (r.superimpose) {
    r.view_a->render(r.cam, ta, r.alphas, &tb, r.ghost_alpha, reduced);
    return;
  }
  r.view_a->render(r.cam, ta, r.alphas, nullptr, 0.35f, reduced);
  r.view_b->render(r.cam, tb, r.alphas, nullptr, 0.35f, reduced);
}

// The views as the window shows them, read back into r.frame (BGR, the free area's size:
// (width - kPanelWidth) x (height - kTimelineHeight)): the headless render.
void read_views(Replay& r) {
  if (!r.view_b) {
    r.view_a->read_bgr(r.frame);
    return;
  }
  const int W = r.opt.width - kPanelWidth, H = r.opt.height - kTimelineHeight;
  r.frame.create(H, W, CV_8UC3);
  r.view_a->read_bgr(r.part);
  r.part.copyTo(r.frame(cv::Rect(0, 0, r.split_w, H)));
  r.view_b->read_bgr(r.part);
  r.part.copyTo(r.frame(cv::Rect(r.split_w, 0, W - r.split_w, H)));
}

void blit_views(Replay& r, ReplayWindow& w) {
  const int W = r.opt.width - kPanelWidth, H = r.opt.height - kTimelineHeight;
  const auto from = [](const SceneView& v) { return std::pair<int, int>(v.rendered_width(), v.rendered_height()); };
  if (!r.view_b) {
    w.blit(r.view_a->framebuffer(), from(*r.view_a), W, H, kPanelWidth, 0);
    return;
  }
  w.blit(r.view_a->framebuffer(), from(*r.view_a), r.split_w, H, kPanelWidth, 0);
  w.blit(r.view_b->framebuffer(), from(*r.view_b), W - r.split_w, H, kPanelWidth + r.split_w, 0);
}

// Loads the recordings, checks the options against them, aligns. Errors are bad input.
ReplayOutcome prepare(Replay& r) {
  const ReplayOptions& o = r.opt;
  auto a = open_recording(o.input, o.exercise);
  if (!a) return {2, a.error()};
  r.a.rec = std::move(a).value();
  if (!(o.at_s >= 0) || o.at_s > r.a.rec.duration_s)
    return {2, "--at " + fmt(o.at_s, 3) + ": must be a time within the recording, 0 to " + fmt(r.a.rec.duration_s, 3) +
                   " s (" + r.a.rec.log_path + ")"};
  if (!o.against.empty()) {
    auto b = open_recording(o.against, o.exercise.empty() ? r.a.rec.exercise.name : o.exercise);
    if (!b) return {2, "--against: " + b.error()};
    r.b = std::make_unique<Side>();
    r.b->rec = std::move(b).value();
    if (std::string why = check_comparable(r.a.rec, r.b->rec); !why.empty()) return {2, "--against: " + why};
    const auto t0 = Clock::now();
    auto w = align_recordings(r.a.rec, r.b->rec);
    r.align_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!w) return {1, "aligning: " + w.error()};
    r.warp = std::move(w).value();
  }
  auto pa = CutPlayer::create(r.a.rec);
  if (!pa) return {2, pa.error()};
  r.a.player = std::move(pa).value();
  if (r.b) {
    auto pb = CutPlayer::create(r.b->rec);
    if (!pb) return {2, "--against: " + pb.error()};
    r.b->player = std::move(pb).value();
  }
  r.superimpose = o.superimpose;
  r.split_w = (o.width - kPanelWidth) / 2;
  r.alphas = {o.enamel_alpha, o.dentin_alpha, o.pulp_alpha};
  // Frame the starting tooth.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  for (const auto& c : r.a.player->surface().chunks())
    for (const auto& v : c.vertices) {
      lo = lo.cwiseMin(v.position_m.cast<double>());
      hi = hi.cwiseMax(v.position_m.cast<double>());
    }
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector3d::Zero();
  r.cam.yaw_rad = o.yaw_deg * M_PI / 180;
  r.cam.pitch_rad = std::clamp(o.pitch_deg * M_PI / 180, -1.55, 1.55);
  r.cam.frame(lo, hi);
  r.cam.distance_m /= o.zoom;
  r.home = r.cam;
  if (Status s = seek(r, o.at_s); !s) return {1, s.error()};
  return {};
}

std::string summary(const Replay& r) {
  std::string s = r.a.rec.log_path + ": " + fmt(r.a.rec.duration_s) + " s, " + std::to_string(r.a.rec.steps.size()) +
                  " step span(s), " + std::to_string(r.a.rec.annotations.size()) + " annotation(s)";
  if (r.b)
    s += "; against " + r.b->rec.log_path + " (" + fmt(r.b->rec.duration_s) + " s), aligned by DTW in " +
         std::to_string(r.warp->steps_aligned.size()) + " step(s), " + fmt(r.align_ms, 0) + " ms";
  if (!r.a.rec.warning.empty()) s += "\nwarning: " + r.a.rec.warning;
  if (r.b && !r.b->rec.warning.empty()) s += "\nwarning (--against): " + r.b->rec.warning;
  return s;
}

// ---- the HUD ------------------------------------------------------------------------------

ImU32 step_colour(int index, float alpha = 1.0f) {
  static const float c[6][3] = {{0.35f, 0.55f, 0.85f}, {0.45f, 0.75f, 0.45f}, {0.85f, 0.6f, 0.3f},
                                {0.7f, 0.45f, 0.8f},   {0.8f, 0.4f, 0.45f},  {0.4f, 0.75f, 0.75f}};
  const auto& k = c[static_cast<std::size_t>(std::max(0, index)) % 6];
  return ImGui::ColorConvertFloat4ToU32(ImVec4(k[0], k[1], k[2], alpha));
}

// The timeline: step bands, annotation markers, the play head; a click seeks. Returns the
// time clicked (or -1).
double timeline(const Recording& rec, double t, float width, float height) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  const double D = std::max(1e-9, rec.duration_s);
  auto X = [&](double s) { return p0.x + static_cast<float>(s / D) * width; };
  dl->AddRectFilled(p0, ImVec2(p0.x + width, p0.y + height), IM_COL32(40, 42, 48, 255));
  for (const auto& s : rec.steps) {
    dl->AddRectFilled(ImVec2(X(s.start_s), p0.y), ImVec2(std::max(X(s.end_s), X(s.start_s) + 1), p0.y + height),
                      step_colour(s.index, 0.55f));
    if (X(s.end_s) - X(s.start_s) > 30) {  // the name, cut at the span's end
      const ImVec4 clip(X(s.start_s), p0.y, X(s.end_s) - 2, p0.y + height);
      const std::string label = std::to_string(s.index + 1) + " " + s.name;
      dl->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(X(s.start_s) + 3, p0.y + 2), IM_COL32(255, 255, 255, 230),
                  label.c_str(), nullptr, 0.0f, &clip);
    }
  }
  for (const auto& a : rec.annotations) {
    const float x = X(a.time_s);
    const ImU32 col = a.pause_s > 0 ? IM_COL32(255, 90, 90, 255) : IM_COL32(255, 230, 120, 255);
    dl->AddTriangleFilled(ImVec2(x - 5, p0.y + height), ImVec2(x + 5, p0.y + height), ImVec2(x, p0.y + height - 9), col);
  }
  // The play head moves every frame: on the foreground list, over the HUD's cached layer
  // (window.h).
  const float xh = X(t);
  ImGui::GetForegroundDrawList()->AddLine(ImVec2(xh, p0.y - 2), ImVec2(xh, p0.y + height + 2), IM_COL32(255, 255, 255, 255),
                                          2.0f);
  ImGui::InvisibleButton("timeline", ImVec2(width, height));
  if (ImGui::IsItemActive() && ImGui::IsMouseDown(0)) {
    const float mx = ImGui::GetIO().MousePos.x;
    return std::clamp(static_cast<double>((mx - p0.x) / width) * D, 0.0, D);
  }
  if (ImGui::IsItemHovered()) {
    for (const auto& a : rec.annotations)
      if (std::abs(ImGui::GetIO().MousePos.x - X(a.time_s)) < 6) ImGui::SetTooltip("%.1f s: %s", a.time_s, a.text.c_str());
  }
  return -1;
}

// The session report's force plot (training/report.cpp force_plot_svg): Fx, Fy, Fz on the
// tooth in the tooth frame over the whole recording, the steps as bands. Drawn once into an
// image (it does not change while playing; as ImGui lines it cost a 720p frame ~30 ms on
// llvmpipe), shown as a texture with the play head over it.
cv::Mat force_plot_image(const Recording& rec, int width, int height) {
  cv::Mat img(height, width, CV_8UC4, cv::Scalar(250, 250, 250, 255));
  const auto& tr = rec.track;
  const double D = std::max(1e-9, rec.duration_s);
  const double t0 = rec.log->records.front().time_s;
  auto X = [&](double s) { return static_cast<int>(std::lround(s / D * (width - 1))); };
  double fmax = 0.5;
  for (const auto& f : tr.force_N) fmax = std::max(fmax, f.cwiseAbs().maxCoeff());
  auto Y = [&](double f) { return static_cast<int>(std::lround((0.5 - 0.5 * f / fmax) * (height - 1))); };
  for (const auto& s : rec.steps)
    cv::rectangle(img, cv::Point(X(s.start_s), 0), cv::Point(X(s.end_s), height - 1),
                  (s.index % 2) ? cv::Scalar(238, 243, 251, 255) : cv::Scalar(246, 246, 246, 255), cv::FILLED);
  cv::line(img, cv::Point(0, Y(0)), cv::Point(width - 1, Y(0)), cv::Scalar(150, 150, 150, 255));
  // RGBA: the report's colours.
  const cv::Scalar col[3] = {cv::Scalar(31, 119, 180, 255), cv::Scalar(44, 160, 44, 255), cv::Scalar(214, 39, 40, 255)};
  for (int a = 0; a < 3; ++a) {
    std::vector<cv::Point> pts;
    pts.reserve(tr.size());
    for (std::size_t i = 0; i < tr.size(); ++i) pts.emplace_back(X(tr.t_s[i] - t0), Y(tr.force_N[i](a)));
    cv::polylines(img, pts, false, col[a], 1, cv::LINE_AA);
  }
  return img;
}

double plot_fmax(const Recording& rec) {
  double fmax = 0.5;
  for (const auto& f : rec.track.force_N) fmax = std::max(fmax, f.cwiseAbs().maxCoeff());
  return fmax;
}

void force_plot(const Recording& rec, unsigned tex, double t, float width, float height, const char* label) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  if (tex != 0)
    ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(tex)), ImVec2(width, height));
  else
    ImGui::Dummy(ImVec2(width, height));
  const double D = std::max(1e-9, rec.duration_s);
  const float x = p0.x + static_cast<float>(t / D) * (width - 1);
  ImGui::GetForegroundDrawList()->AddLine(ImVec2(x, p0.y), ImVec2(x, p0.y + height), IM_COL32(0, 0, 0, 255), 1.5f);
  // The scale's labels built from one named string: GCC 12 raises a false -Wrestrict alarm on
  // `"-" + fmt(...)` (a literal prepended to a temporary string, inlined insert).
  const std::string scale_N = fmt(plot_fmax(rec)) + " N";
  const std::string top = std::string(label) + "  +" + scale_N;
  std::string bottom = "-";
  bottom += scale_N;
  dl->AddText(ImVec2(p0.x + 4, p0.y + 2), IM_COL32(60, 60, 60, 255), top.c_str());
  dl->AddText(ImVec2(p0.x + 4, p0.y + height - 16), IM_COL32(60, 60, 60, 255), bottom.c_str());
  const ImU32 col[3] = {IM_COL32(31, 119, 180, 255), IM_COL32(44, 160, 44, 255), IM_COL32(214, 39, 40, 255)};
  const char* lab[3] = {"Fx mesio-distal", "Fy bucco-lingual", "Fz long axis"};
  for (int a = 0; a < 3; ++a) dl->AddText(ImVec2(p0.x + 330 + 140 * a, p0.y + 2), col[a], lab[a]);
}

int next_step(const Recording& rec, double t, int dir) {
  const int cur = rec.step_at(t + 1e-6);
  const int n = static_cast<int>(rec.steps.size());
  if (n == 0) return -1;
  if (dir > 0) return std::min(cur + 1, n - 1);
  // Back: to the start of the current step, or of the one before when at its start.
  if (cur >= 0 && t - rec.steps[static_cast<std::size_t>(cur)].start_s > 0.5) return cur;
  return std::max(cur - 1, 0);
}

// The window's state between frames.
struct Ui {
  bool playing = false;
  double speed = 1.0;
  double pause_left_s = 0;  // an annotation's pause point holds the clock
  const training::Annotation* shown = nullptr;
  double shown_until = -1;
  bool quit = false;
  double seek_target = -1;  // a jump asked for this frame (keys, clicks), applied by the loop
};

// GLFW key code of a key's name (--keys), -1 when unknown.
int key_code(std::string n) {
  for (auto& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (n.size() == 1 && n[0] >= 'a' && n[0] <= 'z') return GLFW_KEY_A + (n[0] - 'a');
  if (n.size() == 1 && n[0] >= '0' && n[0] <= '9') return GLFW_KEY_0 + (n[0] - '0');
  static const std::pair<const char*, int> named[] = {
      {"space", GLFW_KEY_SPACE}, {"left", GLFW_KEY_LEFT},   {"right", GLFW_KEY_RIGHT},
      {"up", GLFW_KEY_UP},       {"down", GLFW_KEY_DOWN},   {"+", GLFW_KEY_EQUAL},
      {"-", GLFW_KEY_MINUS},     {",", GLFW_KEY_COMMA},     {".", GLFW_KEY_PERIOD},
      {"[", GLFW_KEY_LEFT_BRACKET}, {"]", GLFW_KEY_RIGHT_BRACKET}, {"home", GLFW_KEY_HOME},
      {"end", GLFW_KEY_END},     {"tab", GLFW_KEY_TAB},     {"pagedown", GLFW_KEY_PAGE_DOWN},
      {"pageup", GLFW_KEY_PAGE_UP}, {"escape", GLFW_KEY_ESCAPE}};
  for (const auto& [name, code] : named)
    if (n == name) return code;
  return -1;
}

void handle_keys(Replay& r, Ui& ui, ReplayWindow& w, int scripted) {
  std::vector<int> presses = w.take_presses();
  if (scripted >= 0) presses.push_back(scripted);
  for (int k : presses) {
    const double step = 10 * M_PI / 180;
    switch (k) {
      case GLFW_KEY_ESCAPE: case GLFW_KEY_Q: ui.quit = true; break;
      case GLFW_KEY_SPACE: ui.playing = !ui.playing; break;
      case GLFW_KEY_LEFT: r.cam.orbit(-step, 0); break;
      case GLFW_KEY_RIGHT: r.cam.orbit(step, 0); break;
      case GLFW_KEY_UP: r.cam.orbit(0, step); break;
      case GLFW_KEY_DOWN: r.cam.orbit(0, -step); break;
      case GLFW_KEY_EQUAL: case GLFW_KEY_KP_ADD: r.cam.zoom(1.2); break;
      case GLFW_KEY_MINUS: case GLFW_KEY_KP_SUBTRACT: r.cam.zoom(1 / 1.2); break;
      case GLFW_KEY_W: r.cam.pan(0, -0.05); break;
      case GLFW_KEY_S: r.cam.pan(0, 0.05); break;
      case GLFW_KEY_A: r.cam.pan(-0.05, 0); break;
      case GLFW_KEY_D: r.cam.pan(0.05, 0); break;
      case GLFW_KEY_R: r.cam = r.home; break;
      case GLFW_KEY_COMMA: ui.seek_target = std::max(0.0, r.t_s - 5); break;
      case GLFW_KEY_PERIOD: ui.seek_target = r.t_s + 5; break;
      case GLFW_KEY_LEFT_BRACKET: ui.speed = std::max(0.0625, ui.speed / 2); break;
      case GLFW_KEY_RIGHT_BRACKET: ui.speed = std::min(16.0, ui.speed * 2); break;
      case GLFW_KEY_HOME: ui.seek_target = 0; break;
      case GLFW_KEY_END: ui.seek_target = r.a.rec.duration_s; break;
      case GLFW_KEY_TAB: if (r.b) { r.superimpose = !r.superimpose; (void)make_views(r); } break;
      case GLFW_KEY_N: case GLFW_KEY_PAGE_DOWN: case GLFW_KEY_P: case GLFW_KEY_PAGE_UP: {
        const int s = next_step(r.a.rec, r.t_s, (k == GLFW_KEY_N || k == GLFW_KEY_PAGE_DOWN) ? 1 : -1);
        if (s >= 0) ui.seek_target = r.a.rec.steps[static_cast<std::size_t>(s)].start_s;
        break;
      }
      default:
        if (k >= GLFW_KEY_1 && k <= GLFW_KEY_9) {
          const int want = k - GLFW_KEY_1;  // the exercise's step index
          for (const auto& s : r.a.rec.steps)
            if (s.index == want) {
              ui.seek_target = s.start_s;
              break;
            }
        }
    }
  }
}

void handle_mouse(Replay& r) {
  ImGuiIO& io = ImGui::GetIO();
  if (io.WantCaptureMouse) return;
  if (ImGui::IsMouseDragging(0)) r.cam.orbit(-0.008 * io.MouseDelta.x, 0.008 * io.MouseDelta.y);
  if (ImGui::IsMouseDragging(1) || ImGui::IsMouseDragging(2))
    r.cam.pan(io.MouseDelta.x / r.opt.height, io.MouseDelta.y / r.opt.height);
  if (io.MouseWheel != 0) r.cam.zoom(std::pow(1.1, io.MouseWheel));
}

// A HUD line that changes every frame while playing (the clocks): its place is kept in the
// window and the text drawn on the foreground list, over the HUD's cached layer (window.h).
void live_line(const std::string& text) {
  const ImVec2 at = ImGui::GetCursorScreenPos();
  ImGui::Dummy(ImVec2(ImGui::GetContentRegionAvail().x, ImGui::GetTextLineHeight()));
  ImGui::GetForegroundDrawList()->AddText(at, ImGui::GetColorU32(ImGuiCol_Text), text.c_str());
}

void draw_hud(Replay& r, Ui& ui, double frame_ms) {
  const float W = static_cast<float>(r.opt.width), H = static_cast<float>(r.opt.height);
  const ImGuiWindowFlags fixed = ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                                 ImGuiWindowFlags_NoSavedSettings;
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, H - kTimelineHeight));
  ImGui::Begin("Replay (mode 1)", nullptr, fixed);
  ImGui::TextWrapped("%s", r.a.rec.title.c_str());
  live_line(fmt(r.t_s) + " / " + fmt(r.a.rec.duration_s) + " s   " + fmt(frame_ms, 0) + " ms/frame");
  if (ImGui::Button(ui.playing ? "Pause" : "Play")) ui.playing = !ui.playing;
  ImGui::SameLine();
  if (ImGui::Button("|<")) ui.seek_target = 0;
  ImGui::SameLine();
  if (ImGui::Button("Reset view")) r.cam = r.home;
  float sp = static_cast<float>(ui.speed);
  if (ImGui::SliderFloat("speed", &sp, 0.0625f, 16.0f, "%.2fx", ImGuiSliderFlags_Logarithmic)) ui.speed = sp;
  if (ui.pause_left_s > 0) ImGui::TextColored(ImVec4(1, 0.5f, 0.5f, 1), "pause point: %.1f s", ui.pause_left_s);
  ImGui::Separator();
  ImGui::TextUnformatted("Transparency (opacity)");
  ImGui::SliderFloat("enamel", &r.alphas.enamel, 0.0f, 1.0f, "%.2f");
  ImGui::SliderFloat("dentin", &r.alphas.dentin, 0.0f, 1.0f, "%.2f");
  ImGui::SliderFloat("pulp", &r.alphas.pulp, 0.0f, 1.0f, "%.2f");
  if (r.b) {
    ImGui::Separator();
    bool sup = r.superimpose;
    if (ImGui::Checkbox("superimposed (Tab)", &sup)) {
      r.superimpose = sup;
      (void)make_views(r);
    }
    if (r.superimpose) ImGui::SliderFloat("other", &r.ghost_alpha, 0.05f, 0.95f, "%.2f");
    ImGui::TextWrapped("left/solid: %s", r.a.rec.input.c_str());
    ImGui::TextWrapped("%s: %s", r.superimpose ? "blue" : "right", r.b->rec.input.c_str());
    live_line("  at " + fmt(r.b_time(r.t_s)) + " s (aligned)");
  }
  ImGui::Separator();
  ImGui::TextUnformatted("Steps (1-9; N/P: next/previous change)");
  {
    // Each step of the exercise once, at its first start (the segmentation may come back
    // to a step; the timeline shows every span).
    const int cur = r.a.rec.step_at(r.t_s + 1e-6);
    const int cur_index = cur >= 0 ? r.a.rec.steps[static_cast<std::size_t>(cur)].index : -1;
    for (std::size_t k = 0; k < r.a.rec.exercise.steps.size(); ++k) {
      const StepSpan* first = nullptr;
      for (const auto& s : r.a.rec.steps)
        if (s.index == static_cast<int>(k)) {
          first = &s;
          break;
        }
      const std::string line = std::to_string(k + 1) + " " + r.a.rec.exercise.steps[k].name +
                               (first ? "  " + fmt(first->start_s) + " s" : "  (not found)");
      ImGui::PushID(static_cast<int>(k));
      if (ImGui::Selectable(line.c_str(), cur_index == static_cast<int>(k)) && first) ui.seek_target = first->start_s;
      ImGui::PopID();
    }
  }
  if (!r.a.rec.annotations.empty()) {
    ImGui::Separator();
    ImGui::TextUnformatted("Annotations");
    for (const auto& a : r.a.rec.annotations) {
      ImGui::PushID(&a);
      const std::string line = fmt(a.time_s) + " s  " + (a.pause_s > 0 ? "[pause " + fmt(a.pause_s) + " s] " : "") + a.text;
      if (ImGui::Selectable(line.c_str(), &a == ui.shown)) ui.seek_target = a.time_s;
      ImGui::PopID();
    }
  }
  ImGui::End();

  ImGui::SetNextWindowPos(ImVec2(0, H - kTimelineHeight));
  ImGui::SetNextWindowSize(ImVec2(W, kTimelineHeight));
  ImGui::Begin("Timeline", nullptr, fixed | ImGuiWindowFlags_NoTitleBar | ImGuiWindowFlags_NoScrollbar);
  const float pw = static_cast<float>(static_cast<int>(W) - 16);
  const double clicked = timeline(r.a.rec, r.t_s, pw, 22);
  if (clicked >= 0) ui.seek_target = clicked;
  const float ph = static_cast<float>(r.b ? (kTimelineHeight - 50) / 2 : kTimelineHeight - 46);
  force_plot(r.a.rec, r.plot_a, r.t_s, pw, ph, r.b ? "force (this recording)" : "force on the tooth");
  if (r.b) force_plot(r.b->rec, r.plot_b, r.b_time(r.t_s), pw, ph, "force (--against, at the aligned time)");
  ImGui::End();
}

ReplayOutcome write_png(const std::string& path, const cv::Mat& img) {
  std::error_code ec;
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  try {
    if (!cv::imwrite(path, img)) return {2, path + ": cannot write the image (a .png path in a writable folder?)"};
  } catch (const cv::Exception& e) {
    return {2, path + ": cannot write the image: " + e.what()};
  }
  return {};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t i = static_cast<std::size_t>(std::clamp(p, 0.0, 1.0) * static_cast<double>(v.size() - 1) + 0.5);
  return v[i];
}

}  // namespace

std::string ReplayOptions::validate() const {
  if (input.empty()) return "no recording given";
  if (width < kPanelWidth + 200 || height < kTimelineHeight + 150 || width > 8192 || height > 8192)
    return "--size " + std::to_string(width) + "x" + std::to_string(height) + ": must be at least " +
           std::to_string(kPanelWidth + 200) + "x" + std::to_string(kTimelineHeight + 150) + " and at most 8192x8192";
  if (!(speed >= 0.0625 && speed <= 16)) return "--speed " + fmt(speed, 3) + ": must be 0.0625 to 16";
  if (frames < 0) return "--frames " + std::to_string(frames) + ": must be 0 (until closed) or more";
  if (!(zoom > 0.05 && zoom < 50)) return "--zoom " + fmt(zoom, 3) + ": must be between 0.05 and 50";
  if (!std::isfinite(yaw_deg) || !std::isfinite(pitch_deg)) return "--yaw/--pitch: must be finite";
  for (float a : {enamel_alpha, dentin_alpha, pulp_alpha})
    if (!(a >= 0 && a <= 1)) return "--enamel/--dentin/--pulp: opacity " + fmt(a, 3) + " must be 0 to 1";
  if (!std::isfinite(at_s)) return "--at: must be a number of seconds";
  for (const auto& k : keys)
    if (key_code(k) < 0) return "--keys: unknown key '" + k + "' (letters, digits, space, left, right, up, down, +, -, ',', '.', [, ], home, end, tab, pageup, pagedown, escape)";
  if (!screenshot.empty() && frames <= 0) return "--screenshot needs --frames N (the window is captured after frame N)";
  if (!(play_scale >= 0.25 && play_scale <= 1)) return "--play-scale " + fmt(play_scale, 3) + ": must be 0.25 to 1";
  if (play_lod_voxels != 0 && play_lod_voxels != 2 && play_lod_voxels != 4 && play_lod_voxels != 8)
    return "--play-lod " + std::to_string(play_lod_voxels) + ": must be 0 (the full mesh), 2, 4 or 8 voxels";
  if (!render.empty() && !screenshot.empty()) return "--render (headless) and --screenshot (the window's) exclude each other";
  return {};
}

ReplayOutcome run_replay(const ReplayOptions& opt) {
  if (std::string v = opt.validate(); !v.empty()) return {2, v};
  Replay r;
  r.opt = opt;
  if (auto p = prepare(r); p.exit_code != 0) return p;
  nlohmann::json stats = {{"input", r.a.rec.log_path}, {"duration_s", r.a.rec.duration_s}, {"at_s", r.t_s}};
  if (r.warp) {
    stats["against"] = r.b->rec.log_path;
    stats["align_ms"] = r.align_ms;
    stats["align_cells"] = r.warp->cells;
    stats["steps_aligned"] = r.warp->steps_aligned;
  }
  auto write_stats = [&]() -> ReplayOutcome {
    if (opt.stats.empty()) return {};
    std::ofstream f(opt.stats);
    if (!f) return {2, opt.stats + ": cannot write the statistics"};
    f << stats.dump(1) << "\n";
    return {};
  };

  if (!opt.render.empty()) {
    // Headless: the offline render of the state at --at (what the window's view shows).
    auto ctx = ar::EglContext::create();
    if (!ctx) return {1, "no headless OpenGL ES 3 context: " + ctx.error()};
    if (Status s = make_views(r); !s) return {1, s.error()};
    render_views(r);
    read_views(r);
    if (auto w = write_png(opt.render, r.frame); w.exit_code != 0) return w;
    r.view_a.reset();
    r.view_b.reset();
    if (auto w = write_stats(); w.exit_code != 0) return w;
    return {0, summary(r) + "\nrendered " + opt.render + " at " + fmt(r.t_s, 3) + " s"};
  }

  auto win = ReplayWindow::open("DentAR replay: " + r.a.rec.title, opt.width, opt.height, opt.vsync);
  if (!win) return {2, win.error() + " (for an image without a window: --render PATH)"};
  if ((*win)->width() != opt.width || (*win)->height() != opt.height)
    return {2, "--size " + std::to_string(opt.width) + "x" + std::to_string(opt.height) + ": the display gave a " +
                   std::to_string((*win)->width()) + "x" + std::to_string((*win)->height()) +
                   " window (a smaller screen?); give a --size that fits"};
  if (Status s = make_views(r); !s) return {1, s.error()};
  // The HUD's areas (app.h's layout): the controls on the left, the timeline along the
  // bottom; the views' blits cover the rest.
  (*win)->set_hud_areas({{0, 0, kPanelWidth, opt.height - kTimelineHeight},
                         {0, opt.height - kTimelineHeight, opt.width, kTimelineHeight}});
  {
    // The plots' size as draw_hud lays them out.
    const int pw = opt.width - 16;
    const int ph = r.b ? (kTimelineHeight - 50) / 2 : kTimelineHeight - 46;
    r.plot_a = make_texture(force_plot_image(r.a.rec, pw, ph));
    if (r.b) r.plot_b = make_texture(force_plot_image(r.b->rec, pw, ph));
  }
  Ui ui;
  std::vector<double> last_key;
  ui.playing = opt.play;
  ui.speed = opt.speed;
  std::vector<double> frame_ms, seek_ms, scene_ms, hud_ms, cpu_ms, play_tris;
  // This process's CPU time per frame (all its threads: llvmpipe's rasterisers included, the
  // X server's copy not): the load-independent cost of a frame.
  const auto process_cpu_ms = [] {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
  };
  double last_cpu = process_cpu_ms();
  frame_ms.reserve(static_cast<std::size_t>(std::max(opt.frames, 0)));
  auto last = Clock::now();
  double shown_ms = 0;
  cv::Mat shot;
  for (int n = 0; (opt.frames == 0 || n < opt.frames) && !(*win)->should_close() && !ui.quit; ++n) {
    (*win)->poll();
    handle_keys(r, ui, **win, n >= 1 && n - 1 < static_cast<int>(opt.keys.size())
                                  ? key_code(opt.keys[static_cast<std::size_t>(n - 1)]) : -1);
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    last = now;
    if (n > 0) frame_ms.push_back(dt * 1e3);
    const double cpu_now = process_cpu_ms();
    if (n > 0) cpu_ms.push_back(cpu_now - last_cpu);
    last_cpu = cpu_now;
    shown_ms = 0.9 * shown_ms + 0.1 * dt * 1e3;
    // The clock: playing advances by wall time x speed; a lesson's pause point holds it.
    double t = r.t_s;
    if (ui.seek_target >= 0) {
      t = ui.seek_target;
      ui.seek_target = -1;
      ui.pause_left_s = 0;
    } else if (ui.playing && n > 0) {
      if (ui.pause_left_s > 0) {
        ui.pause_left_s = std::max(0.0, ui.pause_left_s - dt);
      } else {
        const double t1 = std::min(r.a.rec.duration_s, t + dt * ui.speed);
        for (const auto& a : r.a.rec.annotations)
          if (a.pause_s > 0 && a.time_s > t && a.time_s <= t1) {
            ui.pause_left_s = a.pause_s;
            t = a.time_s;
            break;
          }
        if (ui.pause_left_s <= 0) t = t1;
        if (t >= r.a.rec.duration_s) ui.playing = false;
      }
    }
    for (const auto& a : r.a.rec.annotations)
      if (a.time_s <= t + 1e-6 && t - a.time_s < std::max(4.0, a.pause_s + 2)) ui.shown = &a;
    const auto c0 = Clock::now();
    if (t != r.t_s)
      if (Status s = seek(r, t); !s) return {1, s.error()};
    const auto c1 = Clock::now();
    // Playing, the view renders at the reduced level of detail (play_scale); paused, and the
    // frame a --screenshot captures, at full resolution (the key holds which, so pausing
    // renders the same time again at full quality).
    const bool shot_frame = !opt.screenshot.empty() && opt.frames > 0 && n + 1 == opt.frames;
    const bool reduced =
        ui.playing && ui.pause_left_s <= 0 && !shot_frame && (opt.play_scale < 1 || opt.play_lod_voxels > 0);
    // The view is rendered again only when what it shows changed (time, camera, opacities,
    // layout); paused and untouched, the last render is blitted again.
    const std::vector<double> key = {r.t_s, r.cam.yaw_rad, r.cam.pitch_rad, r.cam.distance_m, r.cam.target_m.x(),
                                     r.cam.target_m.y(), r.cam.target_m.z(), r.alphas.enamel, r.alphas.dentin,
                                     r.alphas.pulp, r.ghost_alpha, r.superimpose ? 1.0 : 0.0,
                                     static_cast<double>(reinterpret_cast<std::uintptr_t>(r.view_a.get())),
                                     reduced ? 1.0 : 0.0};
    const bool view_changed = key != last_key;
    if (view_changed) {
      render_views(r, reduced);
      if (reduced) play_tris.push_back(static_cast<double>(r.view_a->rendered_triangles()));
    }
    last_key = key;
    // With --stats, the view's rendering is waited for, so its time is measured apart from
    // the window's (a frame then costs the sum; without, the two can overlap).
    if (!opt.stats.empty()) finish_gl();
    const auto c2 = Clock::now();
    (*win)->begin_frame();
    // An unchanged view that the window still holds (a preserved back buffer) is not
    // copied again: paused and untouched, a frame is the HUD's overlay and the swap.
    if (view_changed || !(*win)->keeps_caller_pixels()) blit_views(r, **win);
    handle_mouse(r);
    draw_hud(r, ui, shown_ms);
    const bool last_frame = opt.frames > 0 && n + 1 == opt.frames;
    cv::Mat px = (*win)->end_frame(last_frame && !opt.screenshot.empty());
    const auto c3 = Clock::now();
    if (n > 0) {
      seek_ms.push_back(std::chrono::duration<double, std::milli>(c1 - c0).count());
      scene_ms.push_back(std::chrono::duration<double, std::milli>(c2 - c1).count());
      hud_ms.push_back(std::chrono::duration<double, std::milli>(c3 - c2).count());
    }
    if (!px.empty()) shot = px;
  }
  delete_texture(r.plot_a);
  delete_texture(r.plot_b);
  r.view_a.reset();
  r.view_b.reset();
  std::string msg = summary(r);
  if (!frame_ms.empty()) {
    const double med = percentile(frame_ms, 0.5), p99 = percentile(frame_ms, 0.99);
    stats["frames"] = frame_ms.size() + 1;
    stats["frame_ms_median"] = med;
    stats["frame_ms_p99"] = p99;
    stats["fps_median"] = med > 0 ? 1e3 / med : 0;
    // Where a frame's time goes (medians, ms): the cut brought to the frame's time, the 3D
    // view (render + read back), the window (upload, HUD, swap).
    stats["cut_ms_median"] = percentile(seek_ms, 0.5);
    stats["view_ms_median"] = percentile(scene_ms, 0.5);
    stats["window_ms_median"] = percentile(hud_ms, 0.5);
    stats["triangles"] = r.a.player->surface().triangle_count();
    stats["size"] = std::to_string(opt.width) + "x" + std::to_string(opt.height);
    stats["play_scale"] = opt.play_scale;
    stats["cpu_ms_median"] = percentile(cpu_ms, 0.5);
    stats["cpu_ms_p99"] = percentile(cpu_ms, 0.99);
    stats["play_lod_voxels"] = opt.play_lod_voxels;
    // The tooth's triangles in the frames rendered while playing (median), and how often the
    // HUD was drawn (the others reused its cached layer).
    stats["triangles_playing"] = percentile(play_tris, 0.5);
    stats["hud_draws"] = (*win)->hud_draws();
    msg += "\nframes: " + std::to_string(frame_ms.size() + 1) + ", frame time median " + fmt(med, 2) + " ms (" +
           fmt(med > 0 ? 1e3 / med : 0, 0) + " fps), p99 " + fmt(p99, 2) + " ms";
  }
  stats["end_s"] = r.t_s;
  stats["speed"] = ui.speed;
  stats["camera"] = {{"yaw_rad", r.cam.yaw_rad}, {"pitch_rad", r.cam.pitch_rad}, {"distance_m", r.cam.distance_m}};
  {
    std::vector<double> starts;
    for (const auto& s : r.a.rec.steps) starts.push_back(s.start_s);
    stats["step_starts_s"] = starts;
  }
  if (!opt.screenshot.empty()) {
    if (shot.empty()) return {1, "no screenshot: the window closed before frame " + std::to_string(opt.frames)};
    if (auto w = write_png(opt.screenshot, shot); w.exit_code != 0) return w;
    msg += "\nscreenshot " + opt.screenshot + " at " + fmt(r.t_s, 3) + " s";
  }
  if (auto w = write_stats(); w.exit_code != 0) return w;
  return {0, msg};
}

}  // namespace dentar::replay
