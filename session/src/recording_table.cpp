// See recording_table.h.
#include "dentar/session/recording_table.h"

#include "dentar/ar/frame_pipeline.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace dentar::session {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> v;
  std::stringstream ss(line);
  std::string c;
  while (std::getline(ss, c, ',')) v.push_back(c);
  if (!line.empty() && line.back() == ',') v.emplace_back();
  return v;
}

// Whole-field integer (no sign for unsigned, no trailing text).
template <typename T>
bool parse_int(const std::string& s, T& out) {
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

bool parse_finite(const std::string& s, double& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(out);
}

}  // namespace

Result<RecordingTable> parse_recording_table(std::istream& in, bool async, const std::string& name, bool both_eyes) {
  RecordingTable t;
  std::string line;
  if (!std::getline(in, line)) return Error{name + ": empty"};
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string> cols = split(line);
  auto col = [&](const char* c) -> int {
    for (std::size_t i = 0; i < cols.size(); ++i)
      if (cols[i] == c) return static_cast<int>(i);
    return -1;
  };
  const int cf = col("frame"), ct = col("time_s"), ch = col("haptic_steps");
  if (cf < 0 || ct < 0 || ch < 0) return Error{name + ": line 1: needs the columns frame, time_s and haptic_steps"};
  const int cs = col("disc_start"), cm = col("disc_merged"), cp = col("pose_step");
  // A stereo live run (issue 28) recorded before the right eye was kept (session 15) has the
  // left eye's frames only: its poses came from both eyes, and a replay from one eye would not
  // be that run.
  const int ce = col("eyes");
  if (ce >= 0 && !both_eyes)
    return Error{name + ": line 1: a stereo run (column eyes) whose recording.json has no \"stereo\": it was "
                 "recorded before `dentar live` kept the right eye (frames_right/), so it holds the left eye's "
                 "frames only and cannot be replayed as the live run tracked it (from both eyes); its frames.csv, "
                 "session.dlog and summary.json are kept as the run's record"};
  if (both_eyes && ce < 0)
    return Error{name + ": line 1: recording.json says the run was stereo, which needs the column eyes "
                 "(the eyes each frame had)"};
  if (async && (cs < 0 || cm < 0))
    return Error{name + ": line 1: recording.json says discovery async, which needs the columns "
                 "disc_start and disc_merged (what the live tracker's search did per frame)"};
  const int need = std::max({cf, ct, ch, async ? std::max(cs, cm) : 0, cp, ce});
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    // The recorder ends every row with a newline: a row without one was cut
    // by a crash. It is not trusted; the frames before it replay.
    if (in.eof()) {
      t.truncated = !line.empty();
      break;
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const std::vector<std::string> v = split(line);
    if (static_cast<int>(v.size()) <= need) {
      return Error{name + ": line " + std::to_string(lineno) + ": " + std::to_string(v.size()) +
                   " fields, the header names " + std::to_string(cols.size())};
    }
    auto bad = [&](int c, const std::string& why) {
      return Error{name + ": line " + std::to_string(lineno) + ", column " + cols[static_cast<std::size_t>(c)] +
                   ": \"" + v[static_cast<std::size_t>(c)].substr(0, 40) + "\" " + why};
    };
    const auto at = [&](int c) -> const std::string& { return v[static_cast<std::size_t>(c)]; };
    long long f = 0;
    if (!parse_int(at(cf), f)) return bad(cf, "is not a frame number");
    const auto expected = static_cast<long long>(t.capture_s.size());
    if (f > expected)
      return bad(cf, "follows frame " + std::to_string(expected - 1) + ": frames " + std::to_string(expected) +
                         ".." + std::to_string(f - 1) +
                         " are missing (the live run could not write them: see frames_not_written in "
                         "recording.json): the tracker cannot be replayed frame for frame across the gap");
    if (f != expected)
      return bad(cf, "is out of order (expected frame " + std::to_string(expected) + ")");
    double time_s = 0;
    if (!parse_finite(at(ct), time_s)) return bad(ct, "is not a finite time in seconds");
    if (!t.capture_s.empty() && time_s < t.capture_s.back())
      return bad(ct, "goes back in time (the frame before was captured at " + std::to_string(t.capture_s.back()) + " s)");
    std::uint64_t steps = 0;
    if (!parse_int(at(ch), steps)) return bad(ch, "is not a step count (a whole number >= 0)");
    if (steps > kMaxRecordedHapticSteps) return bad(ch, "is beyond any session (more than 10^10 steps)");
    if (!t.haptic_steps.empty() && steps < t.haptic_steps.back())
      return bad(ch, "goes back (the engine's step count only grows)");
    if (async) {
      ar::DiscoveryCue cue;
      int start = 0;
      if (!parse_int(at(cs), start) || (start != 0 && start != 1)) return bad(cs, "must be 0 or 1");
      cue.start = start == 1;
      std::int64_t merge = 0;
      if (!parse_int(at(cm), merge) || merge < -1 || merge >= f) return bad(cm, "must be -1 or an earlier frame");
      cue.merge = merge;
      // A merge of a search whose frame did not start one cannot be replayed:
      // dropped, and the replay is marked inexact.
      if (cue.merge >= 0 && !t.cues[static_cast<std::size_t>(cue.merge)].start) {
        cue.merge = -1;
        t.cues_exact = false;
      }
      t.cues.push_back(cue);
    }
    if (cp >= 0) {
      double ps = 0;
      if (!parse_finite(at(cp), ps) || (ps < 0 && ps != -1) || ps > static_cast<double>(steps))
        return bad(cp, "must be -1 or a step between 0 and the row's haptic_steps");
      t.pose_step.push_back(ps);
    }
    if (both_eyes) {
      const std::string& e = at(ce);
      const int eyes = e == "both" ? ar::FrameRecord::kEyesBoth
                       : e == "left" ? ar::FrameRecord::kEyesLeft
                       : e == "right" ? ar::FrameRecord::kEyesRight
                                      : -1;
      if (eyes < 0) return bad(ce, "must be both, left or right");
      t.eyes.push_back(eyes);
    }
    t.capture_s.push_back(time_s);
    t.haptic_steps.push_back(steps);
  }
  if (t.capture_s.empty()) return Error{name + ": no frames recorded"};
  return t;
}

}  // namespace dentar::session
