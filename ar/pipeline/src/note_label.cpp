#include "dentar/ar/note_label.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dentar/ar/camera_model.h"

namespace dentar::ar {

namespace {
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kMaxLines = 4;

int text_w(const std::string& s, double scale, int thick) {
  int base = 0;
  return cv::getTextSize(s, kFont, scale, thick, &base).width;
}

// Words into lines no wider than max_w (a single longer word is cut to fit).
std::vector<std::string> wrap(const std::string& text, double scale, int thick, int max_w) {
  std::vector<std::string> words;
  {
    std::istringstream in(text);
    for (std::string w; in >> w;) words.push_back(w);
  }
  std::vector<std::string> lines;
  std::string cur;
  bool cut = false;
  for (std::string w : words) {
    while (text_w(w, scale, thick) > max_w && w.size() > 1) w.pop_back();
    const std::string t = cur.empty() ? w : cur + " " + w;
    if (cur.empty() || text_w(t, scale, thick) <= max_w) {
      cur = t;
      continue;
    }
    lines.push_back(cur);
    cur = w;
    if (static_cast<int>(lines.size()) == kMaxLines) {
      cut = true;
      break;
    }
  }
  if (!cut && !cur.empty()) lines.push_back(cur);
  if (cut) {
    std::string& last = lines.back();
    while (!last.empty() && text_w(last + "...", scale, thick) > max_w) last.pop_back();
    last += "...";
  }
  return lines;
}
}  // namespace

std::optional<Eigen::Vector2d> tooth_centre_px(const StationScene& station,
                                               const Eigen::Isometry3d& T_cam_man) {
  const CameraModel cam(station.calibration.camera);
  return cam.project((T_cam_man * station.calibration.T_man_tooth).translation());
}

NoteLabelLayout layout_note_label(const std::string& text, const Eigen::Vector2d& anchor,
                                  const cv::Size& frame) {
  NoteLabelLayout l;
  const double s = std::max(0.25, frame.height / 720.0);
  l.font_scale = 0.6 * s;
  l.thickness = std::max(1, static_cast<int>(std::lround(1.5 * s)));
  const int pad = std::max(3, static_cast<int>(std::lround(8 * s)));
  const int gap = std::max(2, static_cast<int>(std::lround(6 * s)));
  const int offset = static_cast<int>(std::lround(40 * s));
  const double ax = std::isfinite(anchor.x()) ? std::clamp(anchor.x(), -1e6, 1e6) : 0;
  const double ay = std::isfinite(anchor.y()) ? std::clamp(anchor.y(), -1e6, 1e6) : 0;
  l.anchor = cv::Point(static_cast<int>(std::lround(ax)), static_cast<int>(std::lround(ay)));
  const int max_w = std::max(40, static_cast<int>(0.4 * frame.width) - 2 * pad);
  l.lines = wrap(text, l.font_scale, l.thickness, max_w);
  if (l.lines.empty()) l.lines.push_back("");
  int base = 0;
  const cv::Size one = cv::getTextSize("Ag", kFont, l.font_scale, l.thickness, &base);
  const int line_h = one.height + base + gap;
  int w = 0;
  for (const std::string& t : l.lines) w = std::max(w, text_w(t, l.font_scale, l.thickness));
  const int bw = std::min(frame.width, w + 2 * pad);
  const int bh = std::min(frame.height, static_cast<int>(l.lines.size()) * line_h - gap + 2 * pad);
  // Above right of the anchor; left when the right has no room; then inside the frame.
  int x = l.anchor.x + offset;
  if (x + bw > frame.width) x = l.anchor.x - offset - bw;
  int y = l.anchor.y - offset - bh;
  if (y < 0) y = l.anchor.y + offset;
  x = std::clamp(x, 0, std::max(0, frame.width - bw));
  y = std::clamp(y, 0, std::max(0, frame.height - bh));
  l.box = cv::Rect(x, y, bw, bh);
  l.leader_end =
      cv::Point(std::clamp(l.anchor.x, x, x + bw - 1), std::clamp(l.anchor.y, y, y + bh - 1));
  for (std::size_t i = 0; i < l.lines.size(); ++i)
    l.baselines.emplace_back(x + pad, y + pad + one.height + static_cast<int>(i) * line_h);
  return l;
}

void draw_note_label(cv::Mat& bgr, const NoteLabelLayout& l, const NoteLabelStyle& st) {
  if (bgr.empty() || l.box.area() <= 0) return;
  const int thick = std::max(1, l.thickness);
  cv::line(bgr, l.anchor, l.leader_end, st.border, thick + 1, cv::LINE_AA);
  cv::circle(bgr, l.anchor, 2 * thick + 1, st.border, cv::FILLED, cv::LINE_AA);
  cv::rectangle(bgr, l.box, st.background, cv::FILLED);
  cv::rectangle(bgr, l.box, st.border, 1);
  for (std::size_t i = 0; i < l.lines.size(); ++i)
    cv::putText(bgr, l.lines[i], l.baselines[i], kFont, l.font_scale, st.text, l.thickness,
                cv::LINE_AA);
}

}  // namespace dentar::ar
