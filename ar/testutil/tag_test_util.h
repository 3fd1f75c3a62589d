// Test helper shared by the tag tests (apriltags_test, synth_gl_test).
#pragma once

#include <gtest/gtest.h>

#include <opencv2/core/mat.hpp>
#include <vector>

#include "dentar/ar/tag_detector.h"

namespace dentar::ar::test {

// Tag detection the way the ground-truth checks need it: full resolution,
// one thread, no blur, edge refinement on (deterministic).
inline std::vector<DetectedTag> detect_full_resolution(const cv::Mat& gray, TagFamilyId family) {
  TagDetectorOptions o;
  o.families = {family};
  o.decimation = 1.0;
  o.threads = 1;
  o.refine_edges = true;
  o.blur_sigma = 0.0;
  auto det = TagDetector::create(o);
  EXPECT_TRUE(det.ok()) << det.error();
  if (!det.ok()) return {};
  auto found = det->detect(gray);
  EXPECT_TRUE(found.ok()) << found.error();
  return found.ok() ? std::move(found).value() : std::vector<DetectedTag>{};
}

}  // namespace dentar::ar::test
