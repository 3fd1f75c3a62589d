// Occlusion by unknown real foreground (fingers, hands, gloves) and the
// mask metrics used to measure it against ground truth.
//
// ForegroundSegmenter classifies the pixels of a small region (the virtual
// tooth's projected region, see compositor.h) as real foreground or as the
// mannequin surface that is expected there. Model: chromaticity (g/r, b/r of
// the sRGB video), which shading and exposure leave nearly unchanged. A pixel
// is foreground when its chromaticity is closer to the foreground colour
// model than to the mannequin's expected albedo at that pixel (rendered by
// the compositor from the mannequin mesh; a blend of the albedos found within
// mix_radius_px counts as expected too, since optical and motion blur mix
// neighbouring surfaces) and close enough to the model in absolute terms. The foreground model starts at a seed colour (bare skin by
// default; set a glove colour in the field) and adapts each frame to the
// mean of the confidently classified pixels, within a bounded distance of
// the seed so it cannot drift onto the mannequin.
//
// CPU only, no GL. Thread: one segmenter per compositing thread (it keeps the
// adapted model between frames).
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <string>

namespace dentar::ar {

struct SegmenterOptions {
  // Seed colour of the foreground, sRGB 0..1 (default: bare skin of the hand).
  Eigen::Vector3d seed_rgb = Eigen::Vector3d(0.86, 0.66, 0.55);
  // Chromaticity distance (in (g/r, b/r) units) beyond which a pixel is never
  // foreground; and the width of the soft transition around the decisions.
  double max_distance = 0.12;
  double softness = 0.02;
  // The expected surface is sampled at the pixel and at +-r and +-r/2 px
  // along both axes; a colour between two of those samples (a blur of their
  // boundary) counts as expected. Covers optical and motion blur up to ~r px.
  // 0 = the pixel only.
  int mix_radius_px = 2;
  // Pixels whose red channel is below this (0..255) are background: a hand
  // under the work light is never that dark, and chromaticity is noise there.
  int min_red = 30;
  // Adaptation: per-frame rate (0 = fixed model, 1 = replace) and the largest
  // distance the model may move from the seed.
  double adapt_rate = 0.2;
  double max_adapt = 0.06;
  std::string validate() const;  // empty, or names the field
};

class ForegroundSegmenter {
 public:
  explicit ForegroundSegmenter(const SegmenterOptions& options = {});

  // video_bgr: CV_8UC3; expected_rgba: CV_8UC4, the mannequin's albedo (sRGB)
  // where alpha > 0, unknown where alpha = 0; region: CV_8UC1, non-zero where
  // to classify. All the same size (views into larger images are fine).
  // fg (re)allocated CV_8UC1: 0..255 foreground probability, 0 outside region.
  // Sizes/types that disagree are a programmer error (asserted).
  void segment(const cv::Mat& video_bgr, const cv::Mat& expected_rgba, const cv::Mat& region,
               cv::Mat& fg);

  // Current foreground model, (g/r, b/r).
  Eigen::Vector2d model_chroma() const { return model_; }
  void reset();  // back to the seed
  const SegmenterOptions& options() const { return options_; }

 private:
  SegmenterOptions options_;
  Eigen::Vector2d seed_, model_;
};

// Evaluation aid: the generator's hand holds the handpiece beside the cheek
// and hardly ever crosses the tooth, so the segmenter is measured on
// generator frames with a synthetic finger painted over them: a capsule from
// a_px to b_px (OpenCV pixels) of radius_px, shaded as a cylinder lit from
// the camera (sRGB colour rgb at full light), with an anti-aliased edge and
// Gaussian noise of noise_dn (8-bit levels, deterministic from seed).
// Paints into bgr (CV_8UC3) and returns the finger's mask (CV_8UC1, 255
// where it covers more than half a pixel).
struct SyntheticFinger {
  Eigen::Vector2d a_px = Eigen::Vector2d::Zero(), b_px = Eigen::Vector2d::Zero();
  double radius_px = 10;
  Eigen::Vector3d rgb = Eigen::Vector3d(0.86, 0.66, 0.55);
  double noise_dn = 1.5;
  unsigned seed = 1;
};
cv::Mat paint_synthetic_finger(cv::Mat& bgr, const SyntheticFinger& finger);

// Agreement of two binary masks (non-zero = inside), same size, CV_8UC1.
struct MaskScore {
  double iou = 1.0;         // |A and B| / |A or B|; 1 when both are empty
  double boundary_f = 1.0;  // F-score of the boundary pixels within the tolerance
  double precision = 1.0, recall = 1.0;  // of the boundary
  int predicted_px = 0, truth_px = 0, intersection_px = 0;
};
// Boundary pixels: inside pixels with a 4-neighbour outside (or on the image
// border). A predicted boundary pixel counts as matched when a truth boundary
// pixel lies within tolerance_px (Euclidean), and vice versa.
MaskScore compare_masks(const cv::Mat& predicted, const cv::Mat& truth, double tolerance_px = 2.0);

}  // namespace dentar::ar
