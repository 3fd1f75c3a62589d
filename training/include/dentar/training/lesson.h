// Lessons (issue 27): an expert's recorded session, made into something a student trains
// against in the five modes (haptics/guidance.h): the recording, the exercise it belongs
// to, the modes' tolerances and the instructor's annotations (text and pause points at
// times or haptic steps of the recording).
//
// On disk a lesson is a folder: lesson.json (docs/formats.md, "Lesson") beside expert.dlog,
// a copy of the recording. The lesson names the recording's content hash, so a lesson whose
// recording was replaced, truncated or damaged is refused rather than trained on.
//
// Units: SI in code; lesson.json holds mm, deg and s (an instructor edits it by hand).
// Thread: any (no engine state here).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dentar/haptics/guidance.h"
#include "dentar/volume/result.h"

namespace dentar::training {

inline constexpr int kLessonVersion = 1;
inline constexpr const char* kLessonFile = "lesson.json";
inline constexpr const char* kLessonRecording = "expert.dlog";

// One annotation, at a time of the recording (s from its first step) or at a haptic step
// (the recording's step counter); exactly one of the two is given in the file, and
// load_lesson resolves a step into its time.
struct Annotation {
  double time_s = -1;        // -1: given by step
  std::int64_t step = -1;    // -1: given by time
  std::string text;          // shown to the student (may be empty for a bare pause)
  double pause_s = 0;        // > 0: a pause point: the expert's clock stops this long
};

struct Lesson {
  std::string path;        // the lesson folder (messages)
  int version = kLessonVersion;
  std::string exercise;    // a built-in exercise name or an exercise file path
  std::string title;
  std::string source;      // what the lesson was made from (recording path, "generated")
  std::string tooth_json;  // the recording's tooth ({"kind": ..., "voxel_mm": ...})
  std::string recording;   // file name inside the folder (expert.dlog)
  std::uint64_t recording_hash = 0;  // ExpertTrack::content_hash of the recording
  std::uint64_t recording_steps = 0;
  double duration_s = 0;
  // The modes' options: guidance field (mode 2), follow tolerance and conditional replay
  // (mode 3), expert speed and force ramp (all). mode = kNone here; a run sets it.
  haptics::TrainingParams params;
  std::vector<Annotation> annotations;  // sorted by time after load_lesson

  std::string recording_path() const { return path + "/" + recording; }
};

// lesson.json from text (fuzz target). Checks the format, version, every field's type and
// range (thresholds negative, eps1 >= eps2, an annotation with both or neither of time and
// step, a negative pause) and names the field; `name` (the file) starts every message.
// Does not read the recording.
Result<Lesson> parse_lesson(const std::string& json_text, const std::string& name);
std::string lesson_json(const Lesson& l);  // the inverse (pretty, stable key order)

// Reads LESSON (a folder, or its lesson.json): parses it, reads the recording and checks its
// content hash and length, resolves step annotations into times, refuses an annotation past
// the end, and checks that the exercise exists and is for the recording's tooth.
// All errors are bad input: they name the file and the field and what to do.
Result<Lesson> load_lesson(const std::string& path);

struct LessonMakeOptions {
  std::string exercise;  // built-in name or exercise file (required)
  std::string title;     // "" = the exercise's title
  std::vector<Annotation> annotations;
  // Add a text annotation at the start of each step of a generated expert's steps.json
  // (cohort generator) when the recording has one.
  bool step_annotations = true;
  haptics::TrainingParams params;  // the modes' options (defaults: haptics/guidance.h)
  std::string source;              // recorded as "source" ("" = the recording's path)
};

// Makes OUT (a new folder; an existing one is refused) from RECORDING: a session log
// (.dlog) or a folder holding session.dlog (`dentar live --record`, `dentar demo`, a cohort
// trial). The recording must read without damage and hold the exercise's tooth.
// Writes into a temporary folder beside OUT and renames it at the end: nothing is half
// written. Returns the lesson as load_lesson reads it back.
Result<Lesson> make_lesson(const std::string& recording, const std::string& out_dir, const LessonMakeOptions& opt);

// A generated expert for a built-in exercise (the cohort generator's expert, seed 1, at the
// exercise's own settings) made into a lesson at OUT: every mode works on a fresh machine,
// with no download. Scratch files go into a temporary folder that is removed.
Result<Lesson> make_generated_lesson(const std::string& exercise, const std::string& out_dir, std::uint64_t seed = 1);

// "builtin:NAME": the generated expert lesson of built-in exercise NAME, made on first use in
// the cache ($DENTAR_CACHE_DIR, else $XDG_CACHE_HOME/dentar, else ~/.cache/dentar;
// lessons/cohort-v<kCohortGeneratorVersion>/NAME) and reused after. Any other text is
// returned as is. Errors: an unknown exercise, no cache folder.
Result<std::string> resolve_lesson_path(const std::string& lesson);

// How long a text annotation stays on show after the expert's clock reaches it (s of the
// expert's clock: a pause point or an expert waiting for the student holds it longer).
inline constexpr double kNoteShowS = 5.0;
// The annotation whose text is on show at the expert's clock `expert_time_s`: the latest one
// with text whose time_s <= expert_time_s < time_s + show_s; -1 when none. `annotations`
// sorted by time (as load_lesson returns them).
int active_note(const std::vector<Annotation>& annotations, double expert_time_s, double show_s = kNoteShowS);

// Human-readable summary (`dentar lesson show`): exercise, recording, duration, drilling
// time, the modes' options in mm/deg, the annotations.
std::string describe_lesson(const Lesson& l);

// "12.5:text", "@12500:text" (a haptic step), "12.5" with pause_s for --pause "12.5:2".
// Errors name the option and the value.
Result<Annotation> parse_annotation_arg(const std::string& arg, bool pause, const std::string& option);

}  // namespace dentar::training
