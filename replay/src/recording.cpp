// See recording.h.
#include "dentar/replay/recording.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "dentar/training/report.h"

namespace dentar::replay {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// {"kind", "voxel_mm"} of a tooth description, for messages and comparisons.
std::string tooth_kind(const std::string& tooth_json) {
  const json j = json::parse(tooth_json, nullptr, false);
  return j.is_object() ? j.value("kind", "?") : "?";
}
double tooth_voxel_mm(const std::string& tooth_json) {
  const json j = json::parse(tooth_json, nullptr, false);
  return j.is_object() && j.contains("voxel_mm") && j["voxel_mm"].is_number() ? j["voxel_mm"].get<double>() : -1;
}

}  // namespace

std::size_t Recording::record_at(double t_s) const {
  const auto& r = log->records;
  if (r.empty()) return 0;
  const double t = r.front().time_s + t_s;
  auto it = std::upper_bound(r.begin(), r.end(), t, [](double v, const haptics::StepRecord& s) { return v < s.time_s; });
  if (it == r.begin()) return 0;
  return static_cast<std::size_t>(it - r.begin()) - 1;
}

double Recording::record_time(std::size_t i) const {
  const auto& r = log->records;
  if (r.empty()) return 0;
  return r[std::min(i, r.size() - 1)].time_s - r.front().time_s;
}

int Recording::step_at(double t_s) const {
  int k = -1;
  for (std::size_t i = 0; i < steps.size(); ++i)
    if (steps[i].start_s <= t_s) k = static_cast<int>(i);
  return k;
}

Result<Recording> open_recording(const std::string& input, const std::string& exercise_override) {
  Recording rec;
  rec.input = input;
  std::string exercise_name = exercise_override;
  std::error_code ec;
  if (input.empty()) return Error{"no recording given: name a session log (.dlog), a session folder or a lesson"};
  std::string path = input;
  if (input.rfind("builtin:", 0) == 0) {
    auto p = training::resolve_lesson_path(input);
    if (!p) return Error{input + ": " + p.error()};
    path = *p;
  }
  if (!fs::exists(path, ec)) return Error{path + ": no such file or folder (give a session log, a session folder or a lesson)"};
  const bool lesson = (fs::is_directory(path, ec) && fs::exists(fs::path(path) / training::kLessonFile, ec)) ||
                      fs::path(path).filename() == training::kLessonFile;
  if (lesson) {
    auto l = training::load_lesson(path);
    if (!l) return Error{l.error()};
    rec.is_lesson = true;
    rec.log_path = l->recording_path();
    rec.annotations = l->annotations;
    rec.title = l->title;
    if (exercise_name.empty()) exercise_name = l->exercise;
  } else if (fs::is_directory(path, ec)) {
    rec.log_path = (fs::path(path) / "session.dlog").string();
    if (!fs::exists(rec.log_path, ec))
      return Error{path + ": a folder without session.dlog or lesson.json (give a session log, a session folder or a lesson)"};
  } else {
    rec.log_path = path;
  }
  auto log = haptics::read_session_log(rec.log_path);
  if (!log) return Error{log.error()};
  rec.warning = log->warning;
  if (log->records.size() < 2)
    return Error{rec.log_path + ": the log holds " + std::to_string(log->records.size()) +
                 " complete haptic step(s), nothing to replay" + (log->warning.empty() ? "" : " (" + log->warning + ")")};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{rec.log_path + ": " + setup.error()};
  rec.setup = *setup;
  if (exercise_name.empty()) exercise_name = training::default_exercise_for(setup->tooth_json);
  auto ex = training::load_named_exercise(exercise_name);
  if (!ex) return Error{ex.error()};
  rec.exercise = std::move(ex).value();
  if (tooth_kind(setup->tooth_json) != tooth_kind(rec.exercise.tooth_json))
    return Error{rec.log_path + ": the recording is of tooth kind '" + tooth_kind(setup->tooth_json) + "', the exercise '" +
                 rec.exercise.name + "' is for tooth kind '" + tooth_kind(rec.exercise.tooth_json) + "'" +
                 " (choose an exercise for this tooth with --exercise)"};
  if (rec.title.empty()) rec.title = rec.exercise.title.empty() ? rec.exercise.name : rec.exercise.title;
  auto start = training::make_start_tooth(setup->tooth_json, setup->volume_hash_start);
  if (!start) return Error{rec.log_path + ": cannot rebuild the session's tooth (header field 'tooth'): " + start.error()};
  auto track = training::decode_session(*log, rec.log_path);
  if (!track) return Error{track.error()};
  rec.track = std::move(track).value();
  auto masks = training::build_masks(rec.exercise, *start);
  if (!masks) return Error{masks.error()};
  rec.frame_steps = training::segment_steps(rec.track, rec.exercise, &*masks, &*start);
  rec.start = std::make_shared<const volume::VoxelVolume>(std::move(start).value());
  rec.log = std::make_shared<const haptics::SessionLog>(std::move(log).value());
  rec.duration_s = rec.log->records.back().time_s - rec.log->records.front().time_s;
  // Steps in time order: runs of equal labels (the segmentation may come back to a step).
  const auto& fs_ = rec.frame_steps;
  const double t0 = rec.log->records.front().time_s;
  for (std::size_t i = 0; i < fs_.size();) {
    std::size_t j = i;
    while (j < fs_.size() && fs_[j] == fs_[i]) ++j;
    StepSpan s;
    s.index = fs_[i];
    s.name = fs_[i] >= 0 && static_cast<std::size_t>(fs_[i]) < rec.exercise.steps.size()
                 ? rec.exercise.steps[static_cast<std::size_t>(fs_[i])].name
                 : "step " + std::to_string(fs_[i] + 1);
    s.start_s = rec.steps.empty() ? 0.0 : std::max(0.0, rec.track.t_s[i] - t0);  // the first from 0
    s.end_s = j < fs_.size() ? rec.track.t_s[j] - t0 : rec.duration_s;
    rec.steps.push_back(s);
    i = j;
  }
  return rec;
}

std::string check_comparable(const Recording& a, const Recording& b) {
  const std::string ka = tooth_kind(a.setup.tooth_json), kb = tooth_kind(b.setup.tooth_json);
  if (ka != kb)
    return b.input + " is a recording of tooth kind '" + kb + "', " + a.input + " of '" + ka +
           "': --against needs a recording of the same tooth (a lesson for the " + ka + ")";
  const double va = tooth_voxel_mm(a.setup.tooth_json), vb = tooth_voxel_mm(b.setup.tooth_json);
  if (std::abs(va - vb) > 1e-9)
    return b.input + " has " + std::to_string(vb) + " mm voxels, " + a.input + " " + std::to_string(va) +
           " mm: --against needs the same tooth at the same voxel size";
  if (a.exercise.name != b.exercise.name)
    return b.input + " is for the exercise '" + b.exercise.name + "', " + a.input + " for '" + a.exercise.name +
           "': the steps to align differ (give the same --exercise to both, or a lesson of this exercise)";
  return {};
}

}  // namespace dentar::replay
