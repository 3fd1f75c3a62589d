// A recording opened for replay (issue 27, mode 1): a session log (.dlog, or a folder
// holding session.dlog) or a lesson (a folder with lesson.json, its lesson.json, or
// builtin:EXERCISE), with what the window shows beside the cut: the exercise's steps found
// in the recording (the session report's segmentation), the lesson's annotations, and the
// force track of the session report's force plot.
//
// Units: SI in code (s, m, N); times are seconds from the recording's first haptic step.
// Thread: any (no GL, no engine thread).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/lesson.h"
#include "dentar/training/session.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::replay {

// One step of the exercise as found in the recording: [start_s, end_s).
struct StepSpan {
  int index = 0;  // the exercise's step index (0-based)
  std::string name;
  double start_s = 0, end_s = 0;
};

struct Recording {
  std::string input;     // what the user gave (messages)
  std::string log_path;  // the session log read
  bool is_lesson = false;
  std::string title;  // the lesson's title, else the exercise's
  std::shared_ptr<const haptics::SessionLog> log;
  haptics::SessionSetup setup;
  std::shared_ptr<const volume::VoxelVolume> start;  // the session's starting tooth
  training::Exercise exercise;
  training::SessionTrack track;       // 100 Hz (decimation 10), the report's force plot
  std::vector<int> frame_steps;       // the step index per track frame (training::segment_steps)
  std::vector<StepSpan> steps;        // the steps in time order, the empty ones left out
  std::vector<training::Annotation> annotations;  // lesson only, sorted by time
  double duration_s = 0;  // last step's time - first step's time
  std::string warning;    // a damaged log: what was kept (the replay goes on with it)

  // Record index shown at time t (the last record at or before t; clamped).
  std::size_t record_at(double t_s) const;
  double record_time(std::size_t i) const;  // seconds from the first record
  // The step (index into `steps`) playing at t, -1 before the first.
  int step_at(double t_s) const;
};

// Opens INPUT. `exercise` overrides the exercise ("" = the lesson's, else by the tooth:
// training::default_exercise_for). Every error is bad input and names the file and what is
// wrong: no such file or folder, not a session log or lesson, a damaged header, a lesson whose
// recording was changed, an exercise for another tooth, a log with no complete block.
Result<Recording> open_recording(const std::string& input, const std::string& exercise = "");

// Empty when `b` can be shown against `a` (same tooth kind and voxel size, same exercise),
// else a message naming both inputs and the mismatch.
std::string check_comparable(const Recording& a, const Recording& b);

}  // namespace dentar::replay
