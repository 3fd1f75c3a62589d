// Camera model choice and hand-eye: accuracy against a known truth, with the time each takes.
//   build/calibration/calibration_bench --benchmark_counters_tabular=true
// BM_CameraModel/<coverage %>: 17 generated chessboard views (9x6, 0.15 px noise) of a known
// 816x612 lens (k1 -0.28, k2 0.10, k3 -0.015, small p1 p2) with every board inside the centred
// rectangle holding that share of the image; 5 seeds. Per candidate model: held-out RMS (mean,
// px) and the worst projection error over the whole image against the truth (median over the
// seeds of each seed's worst pixel, px, after the mrcal-style rotation alignment over the
// boards' pixels); `chosen_*` count how often each was chosen; `trusted_pct` the share of the
// image the map trusts (mean over the accepted runs) and `trusted_worst_px` the worst true
// error inside it (max over seeds); `refused_runs` the runs where every candidate folded inside
// the image and the step refused the calibration.
// Time: one select_camera_model call (5-fold held-out fits of every candidate + trust map).
// BM_HandEye/<method>/<spread deg>: 12 generated pose pairs (noise 1 mrad, 1 mm per axis on
// both poses) whose body orientations differ by up to the spread; 20 seeds; worst rotation
// (deg) and translation (mm) error of T_hand_cam against truth over the runs not refused
// (`refused`: ours refuses motions whose second rotation axis carries < 5 deg). Method 0 ours, 1..5 OpenCV's
// TSAI PARK HORAUD ANDREFF DANIILIDIS. Time: one calibration.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "dentar/calibration/camera_model.h"
#include "dentar/calibration/hand_eye.h"

namespace cal = dentar::calibration;

namespace {

cal::CameraIntrinsics truth_camera() {
  cal::CameraIntrinsics k;
  k.width = 816;
  k.height = 612;
  k.fx = 640;
  k.fy = 642;
  k.cx = 410;
  k.cy = 303;
  k.dist = {-0.28, 0.10, 0.0004, -0.0003, -0.015};
  return k;
}

std::vector<cal::BoardView> views_for(double fraction, std::uint64_t seed) {
  const cal::CameraIntrinsics k = truth_camera();
  const cal::ChessboardSpec board{9, 6, 0.02};
  const auto poses = cal::plan_board_poses_in_region(k, 0.16, 0.10, 17, seed, fraction);
  std::mt19937_64 rng(seed + 100);
  std::normal_distribution<double> n(0.0, 0.15);
  std::vector<cal::BoardView> views;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    cal::BoardView v;
    v.name = "sim-" + std::to_string(i);
    for (const auto& p : board.object_points()) {
      Eigen::Vector2d px;
      if (!cal::project_point(k, poses[i] * p, px)) continue;
      v.image_points.push_back(px + Eigen::Vector2d(n(rng), n(rng)));
      v.object_points.push_back(p);
    }
    views.push_back(std::move(v));
  }
  return views;
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

void BM_CameraModel(benchmark::State& state) {
  const double fraction = state.range(0) / 100.0;
  const cal::Lens truth = cal::Lens::from(truth_camera());
  const char* names[4] = {"k1", "k1k2", "radtan5", "rational8"};
  std::vector<double> heldout[4], worst[4];
  double chosen[4] = {0, 0, 0, 0}, trusted_pct = 0, trusted_worst = 0, refused = 0;
  const int seeds = 5;
  for (int s = 1; s <= seeds; ++s) {
    const auto views = views_for(fraction, 40 + s);
    const cal::ModelSelection sel = cal::select_camera_model(views, 816, 612);
    // No valid model at all (every candidate folds inside the image): the step refuses.
    if (!sel.ok) refused += 1;
    std::vector<Eigen::Vector2d> board_px;
    for (const auto& v : views) board_px.insert(board_px.end(), v.image_points.begin(), v.image_points.end());
    for (int m = 0; m < 4; ++m) {
      const auto& c = sel.candidates[m];
      if (!c.fitted) continue;
      if (c.heldout_rms_px > 0) heldout[m].push_back(c.heldout_rms_px);
      const cal::Lens est = cal::Lens::from(c.fit);
      const Eigen::Matrix3d R = cal::align_rotation(truth, est, board_px);
      double w = 0, wt = 0;
      for (double v = -0.5; v <= 611.5; v += 4)
        for (double u = -0.5; u <= 815.5; u += 4) {
          const double e = cal::projection_error_px(truth, est, R, u, v);
          w = std::max(w, e);
          if (static_cast<int>(sel.model) == static_cast<int>(c.model) &&
              sel.trust.trusted_at(u, v, 816, 612))
            wt = std::max(wt, e);
        }
      worst[m].push_back(w);
      if (sel.ok && c.verdict == "chosen") {
        chosen[m] += 1;
        trusted_worst = std::max(trusted_worst, wt);
      }
    }
    if (sel.ok) trusted_pct += sel.trust.trusted_fraction * 100;
  }
  for (auto _ : state) {
    const auto sel = cal::select_camera_model(views_for(fraction, 41), 816, 612);
    benchmark::DoNotOptimize(sel.ok);
  }
  for (int m = 0; m < 4; ++m) {
    double mean = 0;
    for (double h : heldout[m]) mean += h / heldout[m].size();
    state.counters[std::string(names[m]) + "_heldout_px"] = heldout[m].empty() ? NAN : mean;
    state.counters[std::string(names[m]) + "_worst_px"] = median(worst[m]);
    state.counters[std::string("chosen_") + names[m]] = chosen[m];
  }
  state.counters["refused_runs"] = refused;
  state.counters["trusted_pct"] = refused < seeds ? trusted_pct / (seeds - refused) : NAN;
  state.counters["trusted_worst_px"] = trusted_worst;
}
BENCHMARK(BM_CameraModel)->Arg(30)->Arg(50)->Arg(90)->Iterations(1)->Unit(benchmark::kMillisecond);

Eigen::Isometry3d he_X() {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = (Eigen::AngleAxisd(-20 * M_PI / 180, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  X.translation() = Eigen::Vector3d(0.01, -0.03, 0.08);
  return X;
}
Eigen::Isometry3d he_Z() {
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();
  Z.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Z.translation() = Eigen::Vector3d(0.2, 0.1, 1.5);
  return Z;
}

void BM_HandEye(benchmark::State& state) {
  const auto method = static_cast<cal::HandEyeMethod>(state.range(0));
  const double spread = state.range(1) * M_PI / 180;
  auto run = [&](const std::vector<cal::HandEyeObservation>& obs) {
    return method == cal::HandEyeMethod::kOurs ? cal::calibrate_hand_eye(obs)
                                               : cal::calibrate_hand_eye_opencv(obs, method);
  };
  double wr = 0, wt = 0, refused = 0;
  std::vector<double> rot;
  for (int s = 1; s <= 20; ++s) {
    std::mt19937_64 rng(s);
    const auto r = run(cal::simulate_hand_eye(he_X(), he_Z(), 12, spread, 1e-3, 1e-3, rng));
    if (!r.ok) {  // ours refuses motions about (nearly) one axis; counted, not scored
      refused += 1;
      continue;
    }
    const double er = cal::rotation_error_rad(r.T_hand_cam, he_X()) * 180 / M_PI;
    const double et = cal::translation_error_m(r.T_hand_cam, he_X()) * 1e3;
    wr = std::max(wr, er);
    wt = std::max(wt, et);
    rot.push_back(er);
  }
  std::mt19937_64 rng(1);
  const auto obs = cal::simulate_hand_eye(he_X(), he_Z(), 12, spread, 1e-3, 1e-3, rng);
  for (auto _ : state) benchmark::DoNotOptimize(run(obs).ok);
  state.SetLabel(cal::hand_eye_method_name(method));
  state.counters["worst_rot_deg"] = wr;
  state.counters["median_rot_deg"] = median(rot);
  state.counters["worst_trans_mm"] = wt;
  state.counters["refused"] = refused;
}
BENCHMARK(BM_HandEye)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5}, {20, 60, 90, 120, 150, 175}})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
