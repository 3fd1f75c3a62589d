// Student against expert, per step (issue 27: the seed's unfinished idea): two recordings
// of the same exercise are aligned in time by dynamic time warping (training::dtw_align,
// multi-resolution) within each step the session report's segmentation found, so a step
// never borrows time from its neighbour, and the pieces are joined into one map from the
// first recording's time to the second's. The series aligned is the bur tip in the tooth
// frame (mm) at the track's 100 Hz: where the bur is is what a viewer compares.
//
// A step found in only one of the two recordings gets no DTW: the map runs straight
// (linearly) across it to the next step both have.
//
// Units: seconds from each recording's first haptic step. Thread: any.
#pragma once

#include <vector>

#include "dentar/replay/recording.h"
#include "dentar/training/align.h"

namespace dentar::replay {

// Per-step DTW of two series given their step label per row (labels need not be contiguous:
// a step's rows run from its first row to the first row of any later step). Returns, per row
// of a, the (fractional) row of b shown with it: monotone, from 0 to rows_b - 1.
// Errors: empty or mismatched inputs (named), training::dtw_align's.
struct StepWarp {
  std::vector<double> b_row;      // per row of a
  std::vector<int> steps_aligned; // the step labels aligned by DTW (present in both)
  std::size_t cells = 0;          // DTW cells evaluated, all steps
  double cost = 0;                // sum of the steps' DTW costs
};
Result<StepWarp> align_by_step(const training::Series& a, const std::vector<int>& steps_a, const training::Series& b,
                               const std::vector<int>& steps_b, int radius = 8);

// The two recordings' tip tracks (mm) aligned by step.
struct TimeWarp {
  std::vector<double> a_t_s;  // a's track times (s from its start)
  std::vector<double> b_t_s;  // b's time shown at each of them
  std::vector<int> steps_aligned;
  std::size_t cells = 0;
  double b_at(double a_s) const;  // linear between frames, clamped
};
Result<TimeWarp> align_recordings(const Recording& a, const Recording& b, int radius = 8);

// The tip track of a recording as a series (mm, 3 columns).
training::Series tip_series_mm(const training::SessionTrack& t);

}  // namespace dentar::replay
