// Kalibr's AprilGrid: see calib_board.h (detect_kalibr_aprilgrid) for the method.
#include <apriltag/apriltag.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "dentar/ar/apriltags.h"
#include "dentar/ar/calib_board.h"

namespace dentar::ar {

namespace {

// tag36h11's code table read with a 2-cell border: libapriltag's family struct, copied, its bit
// positions one cell further in and its border square 10 cells wide. The detector keeps a pointer
// to `fam` (and its quick-decode table in fam.impl, freed by apriltag_detector_destroy).
struct KalibrDecoder {
  TagFamily base = TagFamily::create(TagFamilyId::kTag36h11);
  apriltag_family_t fam{};
  std::vector<std::uint32_t> bx, by;
  apriltag_detector_t* det = nullptr;

  KalibrDecoder() {
    const apriltag_family_t* b = base.raw();
    fam = *b;
    fam.impl = nullptr;
    bx.assign(b->bit_x, b->bit_x + b->nbits);
    by.assign(b->bit_y, b->bit_y + b->nbits);
    for (auto& v : bx) v += 1;
    for (auto& v : by) v += 1;
    fam.bit_x = bx.data();
    fam.bit_y = by.data();
    fam.width_at_border = b->width_at_border + 2;
    fam.total_width = fam.width_at_border + 2;
    det = apriltag_detector_create();
    det->quad_decimate = 1.0f;
    det->quad_sigma = 0.0f;
    det->nthreads = 1;
    det->refine_edges = 1;
    det->decode_sharpening = 0.25;
    apriltag_detector_add_family_bits(det, &fam, 2);
  }
  ~KalibrDecoder() {
    if (det) apriltag_detector_destroy(det);
  }
  KalibrDecoder(const KalibrDecoder&) = delete;
  KalibrDecoder& operator=(const KalibrDecoder&) = delete;
};

struct Found {
  std::array<Eigen::Vector2d, 4> corners;
  double margin = 0;
};

}  // namespace

Result<calibration::BoardView> detect_kalibr_aprilgrid(const cv::Mat& gray, const calibration::AprilGridSpec& spec,
                                                       const std::string& name, int min_tags,
                                                       KalibrGridStats* stats) {
  if (gray.empty() || gray.type() != CV_8UC1) return Error{name + ": need an 8-bit grey image"};
  if (!spec.kalibr) return Error{name + ": the board is not a Kalibr AprilGrid (kalibr:...)"};
  if (std::string e = spec.validate(); !e.empty()) return Error{name + ": " + e};
  KalibrDecoder dec;
  std::map<int, Found> tags;  // by id
  // Passes: (upsampling, dilation). Upsampled twice, a 3x3 dilation opens the corner contacts
  // while taking only half a pixel off the bits (small tags' cells are 3-4 px).
  const std::pair<int, int> passes[] = {{1, 3}, {2, 3}, {2, 5}};
  for (const auto& [up, k] : passes) {
    cv::Mat work, big;
    if (up > 1) cv::resize(gray, big, cv::Size(), up, up, cv::INTER_LINEAR);
    else big = gray;
    cv::dilate(big, work, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
    if (!work.isContinuous()) work = work.clone();
    image_u8_t im{work.cols, work.rows, static_cast<int32_t>(work.step[0]), work.data};
    zarray_t* found = apriltag_detector_detect(dec.det, &im);
    if (!found) continue;
    for (int i = 0; i < zarray_size(found); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(found, i, &d);
      if (!spec.has_id(d->id) || d->hamming > 1 || tags.count(d->id)) continue;
      Found f;
      for (int c = 0; c < 4; ++c) f.corners[c] = Eigen::Vector2d(d->p[c][0] / up - 0.5, d->p[c][1] / up - 0.5);
      f.margin = d->decision_margin;
      tags[d->id] = f;
    }
    apriltag_detections_destroy(found);
    if (static_cast<int>(tags.size()) == spec.tag_count()) break;
  }
  calibration::BoardView v;
  v.name = name;
  int kept = 0, dropped = 0;
  for (const auto& [id, f] : tags) {
    double side = 0;
    for (int c = 0; c < 4; ++c) side += (f.corners[c] - f.corners[(c + 1) % 4]).norm() / 4;
    const double gap_px = side * spec.gap_m / spec.tag_size_m;
    const int win = std::clamp(static_cast<int>(std::lround(gap_px / 3)), 2, 12);
    std::vector<cv::Point2f> pts;
    for (const auto& c : f.corners) pts.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    bool inside = true;
    for (const auto& p : pts)
      inside = inside && p.x >= win + 1 && p.y >= win + 1 && p.x < gray.cols - win - 2 && p.y < gray.rows - win - 2;
    if (!inside) {
      ++dropped;
      continue;
    }
    const std::vector<cv::Point2f> start = pts;
    cv::cornerSubPix(gray, pts, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.01));
    bool ok = true;
    for (std::size_t c = 0; c < 4; ++c) ok = ok && cv::norm(pts[c] - start[c]) <= win;
    if (!ok) {
      ++dropped;
      continue;
    }
    const auto obj = spec.tag_corners(id);
    for (int c = 0; c < 4; ++c) {
      v.image_points.emplace_back(pts[static_cast<std::size_t>(c)].x, pts[static_cast<std::size_t>(c)].y);
      v.object_points.push_back(obj[static_cast<std::size_t>(c)]);
    }
    ++kept;
  }
  if (stats) {
    stats->tags = kept;
    stats->dropped_at_refinement = dropped;
  }
  if (kept < min_tags) {
    std::ostringstream os;
    os << "board not found in " << name << " (" << kept << " tags of the Kalibr AprilGrid seen, need " << min_tags
       << "): check --board (kalibr:COLSxROWS:TAG_MM:SPACING_RATIO, first id), focus and lighting";
    return Error{os.str()};
  }
  return v;
}

}  // namespace dentar::ar
