// The camera step's chessboard finder (calibration::detect_chessboard) on OpenCV's 26 real
// chessboard photos (Debian package opencv-doc) and on generated views (ar::render_board_view),
// each photo also with N draws of uniform {-1, 0, +1} grey noise. Per view and draw: whether a
// board is found, its smoothness (homography RMS and the grid's largest second difference
// relative to the corner spacing), its corners against the classic finder's on the clean photo
// (findChessboardCorners + cornerSubPix, window inside the squares; also with OpenCV's 11x11
// window), the finder's CPU time; then
// the camera's calibration from the 13 left photos (clean) as the finder returns them.
//   ar_chessboard_photo_bench [--draws N] [--dir DIR] [--sim COUNT]
// Prints one line per view/draw ("view ...") and a summary. docs/BENCHMARKS.md, calibration
// session 19.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dentar/ar/calib_board.h"
#include "dentar/calibration/chessboard_grid.h"
#include "dentar/calibration/intrinsics.h"

namespace fs = std::filesystem;
using namespace dentar;

namespace {

double cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double x = q * static_cast<double>(v.size() - 1);
  const std::size_t i = static_cast<std::size_t>(x);
  return i + 1 < v.size() ? v[i] + (x - i) * (v[i + 1] - v[i]) : v[i];
}

// Largest |p[k-1] - 2 p[k] + p[k+1]| / (|p[k+1] - p[k-1]| / 2) along the rows and the columns.
double second_difference(const calibration::BoardView& v, int cols, int rows) {
  double worst = 0;
  auto at = [&](int r, int c) { return v.image_points[static_cast<std::size_t>(r * cols + c)]; };
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (c > 0 && c + 1 < cols)
        worst = std::max(worst, (at(r, c - 1) - 2 * at(r, c) + at(r, c + 1)).norm() /
                                    (0.5 * (at(r, c + 1) - at(r, c - 1)).norm()));
      if (r > 0 && r + 1 < rows)
        worst = std::max(worst, (at(r - 1, c) - 2 * at(r, c) + at(r + 1, c)).norm() /
                                    (0.5 * (at(r + 1, c) - at(r - 1, c)).norm()));
    }
  return worst;
}

// Largest distance from a corner to the nearest of the reference's (the finder may number the
// grid from either end).
double max_nearest(const calibration::BoardView& a, const std::vector<cv::Point2f>& ref) {
  double worst = 0;
  for (const Eigen::Vector2d& p : a.image_points) {
    double best = 1e9;
    for (const cv::Point2f& q : ref) best = std::min(best, std::hypot(p.x() - q.x, p.y() - q.y));
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  int draws = 20, sim = 24;
  fs::path dir = "/usr/share/doc/opencv-doc/examples/data";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--draws") && i + 1 < argc) draws = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--dir") && i + 1 < argc) dir = argv[++i];
    else if (!std::strcmp(argv[i], "--sim") && i + 1 < argc) sim = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--draws N] [--dir DIR] [--sim COUNT]\n", argv[0]);
      return 2;
    }
  }
  calibration::ChessboardSpec spec;
  spec.cols = 9;
  spec.rows = 6;
  spec.square_m = 0.025;
  std::vector<double> cpu, hom_good, d2_good, agree;
  int runs = 0, found = 0, bad = 0, refused = 0;
  std::vector<calibration::BoardView> left;
  int width = 0, height = 0;
  for (const char* side : {"left", "right"})
    for (int n = 1; n <= 14; ++n) {
      char name[32];
      std::snprintf(name, sizeof name, "%s%02d.jpg", side, n);
      const cv::Mat g = cv::imread((dir / name).string(), cv::IMREAD_GRAYSCALE);
      if (g.empty()) continue;
      width = g.cols;
      height = g.rows;
      std::vector<cv::Point2f> ref;
      const bool ref_ok = cv::findChessboardCorners(g, cv::Size(9, 6), ref,
                                                    cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      if (ref_ok)
        cv::cornerSubPix(g, ref, cv::Size(11, 11), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
      // The classic finder with the window kept inside the squares (as detect_chessboard
      // refines): OpenCV's fixed 11 px window slides left02's last column 2-8 px.
      std::vector<cv::Point2f> ref_in = ref;
      if (ref_ok) {
        ref_in.clear();
        cv::findChessboardCorners(g, cv::Size(9, 6), ref_in, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
        std::vector<Eigen::Vector2d> p;
        for (const cv::Point2f& q : ref_in) p.emplace_back(q.x, q.y);
        calibration::refine_chessboard_corners(g.data, g.cols, g.rows, static_cast<int>(g.step), 9, 6, p);
        for (std::size_t i = 0; i < ref_in.size(); ++i)
          ref_in[i] = cv::Point2f(static_cast<float>(p[i].x()), static_cast<float>(p[i].y()));
      }
      cv::RNG rng(1000 + n + (side[0] == 'r') * 100);
      for (int d = 0; d <= draws; ++d) {
        cv::Mat img = g;
        if (d > 0) {
          cv::Mat noise(g.size(), CV_16S), sum;
          rng.fill(noise, cv::RNG::UNIFORM, -1, 2);
          g.convertTo(sum, CV_16S);
          sum += noise;
          sum.convertTo(img, CV_8U);
        }
        const double t0 = cpu_ms();
        auto v = calibration::detect_chessboard(img.data, img.cols, img.rows, static_cast<int>(img.step), spec, name);
        const double t = cpu_ms() - t0;
        cpu.push_back(t);
        ++runs;
        if (!v) {
          ++refused;
          std::printf("view %s draw %d refused cpu %.0f ms: %s\n", name, d, t, v.error().c_str());
          continue;
        }
        ++found;
        const double h = calibration::board_homography_rms_px(*v), s = second_difference(*v, 9, 6);
        const double a11 = ref_ok ? max_nearest(*v, ref) : NAN;
        const double a = ref_ok ? max_nearest(*v, ref_in) : NAN;
        const bool is_bad = ref_ok && a > 3;  // a corner 3 px from every classic corner
        bad += is_bad;
        if (!is_bad) {
          hom_good.push_back(h);
          d2_good.push_back(s);
          if (ref_ok) agree.push_back(a);
        }
        std::printf("view %s draw %d found hom %.3f d2 %.3f classic-max %.3f %s cpu %.0f ms classic11-max %.3f\n", name,
                    d, h, s, a, is_bad ? "BAD" : "ok", t, a11);
        if (d == 0 && side[0] == 'l') left.push_back(*v);
      }
      std::fflush(stdout);
    }
  std::printf("\nphotos: %d runs, %d boards, %d refused, %d bad (a corner > 3 px from the classic finder's)\n",
              runs, found, refused, bad);
  std::printf("good boards: homography rms p50 %.3f p99 %.3f max %.3f px; second difference p50 %.3f p99 %.3f max %.3f\n",
              quantile(hom_good, 0.5), quantile(hom_good, 0.99), quantile(hom_good, 1), quantile(d2_good, 0.5),
              quantile(d2_good, 0.99), quantile(d2_good, 1));
  std::printf("corner agreement with the classic finder (good boards, max per board): p50 %.3f p95 %.3f max %.3f px\n",
              quantile(agree, 0.5), quantile(agree, 0.95), quantile(agree, 1));
  std::printf("finder CPU per view: p50 %.0f p99 %.0f max %.0f ms\n", quantile(cpu, 0.5), quantile(cpu, 0.99),
              quantile(cpu, 1));
  if (left.size() >= 3) {
    calibration::IntrinsicsOptions o;
    auto s = calibration::calibrate_intrinsics(left, width, height, o);
    std::printf("calibration from %zu clean left views: %s fx %.3f fy %.3f cx %.3f cy %.3f RMS %.4f px\n", left.size(),
                s.ok ? "ok" : "FAILED", s.camera.fx, s.camera.fy, s.camera.cx, s.camera.cy, s.rms_px);
  }

  // Generated views: 640x480, truth known; smoothness of the found boards.
  if (sim > 0) {
    calibration::CameraIntrinsics k;
    k.width = 640;
    k.height = 480;
    k.fx = k.fy = 540;
    k.cx = 318;
    k.cy = 242;
    k.dist = {-0.28, 0.1, 0, 0, 0};
    const ar::BoardSpec bs = spec;
    std::vector<double> sh, sd, serr;
    int sfound = 0;
    for (std::uint64_t seed : {1u, 2u}) {
      const auto sess = ar::simulate_board_session(bs, k, sim, seed);
      for (std::size_t i = 0; i < sess.images.size(); ++i) {
        const cv::Mat& img = sess.images[i];
        auto v = calibration::detect_chessboard(img.data, img.cols, img.rows, static_cast<int>(img.step), spec, "sim");
        if (!v) continue;
        ++sfound;
        sh.push_back(calibration::board_homography_rms_px(*v));
        sd.push_back(second_difference(*v, 9, 6));
        const auto truth = ar::project_board_points(bs, k, sess.T_cam_board[i]);
        double worst = 0;
        for (const auto& p : v->image_points) {
          double best = 1e9;
          for (const auto& q : truth) best = std::min(best, (p - q).norm());
          worst = std::max(worst, best);
        }
        serr.push_back(worst);
      }
    }
    std::printf("generated (k1 -0.28, 640x480, %d views): %d boards; homography rms p50 %.3f max %.3f px; second "
                "difference p50 %.3f max %.3f; corner error to truth max per board p50 %.3f max %.3f px\n",
                2 * sim, sfound, quantile(sh, 0.5), quantile(sh, 1), quantile(sd, 0.5), quantile(sd, 1),
                quantile(serr, 0.5), quantile(serr, 1));
  }
  return 0;
}
