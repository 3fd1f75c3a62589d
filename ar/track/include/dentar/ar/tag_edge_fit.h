// Issue 28 session 21: a tag's border square fitted to the image's edges where its pose
// predicts it, without decoding (for a tag the detector cannot read in a blurred frame).
//
// The border square (the four corners libapriltag reports) is edged by two full rings of
// cells: the ring just inside it and the ring just outside have opposite colours along the
// whole side (tagStandard41h12: white inside, black outside; tag36h11: black inside, white
// outside). Along each side's outward normal, within +-reach of the predicted line, the
// side's offset is where that edge's gradient (its known sign) summed over the side is
// largest: the ring runs the side's whole length, a data cell's edge only part of it. Each
// sample point's edge is then the centroid of its gradient lobe around that offset: a
// straight motion blur across a step makes a ramp whose middle is the step at mid-exposure
// (the pose's time), and the lobe's centroid is that middle. A line per side (total least
// squares, points over 1 px off dropped once), the corners where adjacent sides' lines
// meet.
//
// OpenCV pixel convention (distorted image px, as the detector's corners); libapriltag's
// corner order.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace dentar::ar {

struct TagEdgeFitOptions {
  int samples_per_side = 11;    // sample points along each side (its middle 60 %), >= 6
  double min_gradient = 6.0;    // grey levels per px for a sample's edge to count
  double max_rms_px = 0.5;      // a side's points about their line
  double max_shape_px = 2.0;    // the fitted square's shape (corners less their mean shift) against the prediction's
  int min_points_per_side = 6;  // sample points with an edge left on each side
  // A sample's gradient lobe (its width down to 30 % of its peak) wider than this many of the
  // tag's cells is dropped: blurred across wider than the border ring (one cell), the ramp
  // runs into the neighbouring rings' edges (data cells of either colour) and its middle moves
  // (rendered tags, 20 px side, 6 px blur: corners up to 1.9 px off without this bound).
  double max_lobe_cells = 1.5;
  std::string validate() const;  // empty when valid, else names the field
};

enum class TagEdgeFitStatus {
  kFitted,
  kAmbiguous,      // another square (predicted or decoded) lies within the reach
  kNoEdges,        // a side without enough edge points, or its points not on a line
  kOffPrediction,  // the fitted square's shift over the reach or its shape over max_shape_px
  kBadInput,       // see `message`
};
const char* tag_edge_fit_status_name(TagEdgeFitStatus s);  // "fitted", "ambiguous", ...

struct TagEdgeFit {
  TagEdgeFitStatus status = TagEdgeFitStatus::kBadInput;
  std::array<Eigen::Vector2d, 4> corners_px{};  // kFitted: the fitted square's corners
  std::array<double, 4> side_rms_px{};          // each side's points about its line (px)
  double shift_px = 0, shape_px = 0;            // against the prediction
  std::string message;                          // kBadInput: what was wrong
};

// gray: CV_8UC1 image (valid at least within reach + 2 px of the predicted square);
// predicted_px: the tag's predicted corners; inside_bright: the ring inside the border square
// is the bright one (reversed-border families); border_cells: cells along the border square's
// side (TagFamily::width_at_border: 5 for tagStandard41h12, 8 for tag36h11); reach_px: how far the prediction may be off
// (> 0); outer_extent: how far the tag's cells reach beyond its border square, as a fraction
// of its side; others_px: every other square predicted or decoded in the image (their cells
// grown by outer_extent). A square whose cells come within the reach of this one's refuses
// the fit (kAmbiguous). to_linear: the camera response's grey level -> linear light table
// (TagDetector::to_linear); the edges are found in linear light, where the blur and the
// optics average light (in sRGB codes a blurred edge's middle leans to the dark side:
// ~0.2 px per side measured on rendered sharp tags). nullptr: the grey levels as they are.
TagEdgeFit fit_tag_border(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& predicted_px,
                          bool inside_bright, int border_cells, double reach_px, double outer_extent,
                          const std::vector<std::array<Eigen::Vector2d, 4>>& others_px,
                          const TagEdgeFitOptions& options = {},
                          const std::array<double, 256>* to_linear = nullptr);

}  // namespace dentar::ar
