// A lesson's note drawn inside the AR view, beside the tooth (issue 27): a text box on a
// solid background, placed next to the tooth's centre as projected into the composite and
// tied to it by a leader line, clamped inside the frame. The frame pipeline draws it into
// the CPU composite (FrameInput::note), so `dentar live --lesson` (CPU display path) and
// `dentar offline` of a lesson's session show the same label; the live GPU display path
// draws the same layout over its textures in the window (live_display.cpp).
//
// Units: px of the composite (the camera's distorted image, OpenCV pixel centres).
// Thread: any (pure functions; drawing writes only the given image).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/station_scene.h"

namespace dentar::ar {

// The colours (BGR) of the label. The background is solid (no blending), so the label reads
// the same over any video.
struct NoteLabelStyle {
  cv::Scalar background{96, 40, 12};  // dark blue
  cv::Scalar border{255, 215, 110};   // light blue: the box's edge, the leader line, the dot
  cv::Scalar text{255, 255, 255};
};

struct NoteLabelLayout {
  cv::Point anchor;                  // the tooth's centre (may lie outside the frame)
  cv::Rect box;                      // inside the frame
  cv::Point leader_end;              // on the box's edge nearest the anchor
  std::vector<std::string> lines;    // the text, wrapped
  std::vector<cv::Point> baselines;  // each line's origin (cv::putText)
  double font_scale = 0.6;
  int thickness = 1;
};

// The tooth's centre (the tooth frame's origin: the crown's centre on the cervical plane,
// docs/conventions.md) in the composite's pixels, through the station's tooth placement
// (T_man_tooth) and camera model; nullopt behind the camera.
std::optional<Eigen::Vector2d> tooth_centre_px(const StationScene& station,
                                               const Eigen::Isometry3d& T_cam_man);

// Where the label goes for `text` anchored at `anchor` in a frame of `frame` size: the font
// scales with the frame's height (0.6 at 720 rows), the text wraps at words to at most 40 %
// of the frame's width (4 lines at most, the last ending in "..." when cut), the box sits
// above and to the right of the anchor (to the left when the right has no room) and is
// moved inside the frame.
NoteLabelLayout layout_note_label(const std::string& text, const Eigen::Vector2d& anchor,
                                  const cv::Size& frame);

// Draws the layout into a BGR image of the layout's frame size: the leader line and the
// anchor's dot, then the box and its text (over the line).
void draw_note_label(cv::Mat& bgr, const NoteLabelLayout& l, const NoteLabelStyle& style = {});

}  // namespace dentar::ar
