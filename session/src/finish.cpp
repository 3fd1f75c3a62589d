#include "dentar/session/finish.h"

#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dentar/ar/station_scene.h"
#include "dentar/haptics/session_log.h"
#include "dentar/session/frames_csv.h"
#include "dentar/store/record.h"
#include "dentar/store/station.h"
#include "dentar/training/report.h"

namespace dentar::session {
namespace fs = std::filesystem;

namespace {
std::string fmt1(double v) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << v;
  return s.str();
}
std::string esc(const std::string& in) {
  std::string o;
  for (char c : in) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}
}  // namespace

Result<training::SightGeometry> sight_from_station(const std::string& station_json) {
  auto st = ar::read_station_scene(station_json);
  if (!st) return Error{st.error()};
  const auto& c = st->calibration;
  training::SightGeometry g;
  g.T_man_tooth = c.T_man_tooth;
  g.T_mtag_mir = c.T_mtag_mir;
  g.mirror_radius_m = c.mirror_radius_m;
  if (c.camera.fx > 0 && c.camera.fy > 0) {
    g.tan_half_fov_x = 0.5 * c.camera.width / c.camera.fx;
    g.tan_half_fov_y = 0.5 * c.camera.height / c.camera.fy;
  }
  return g;
}

std::string check_exercise(const std::string& exercise) {
  if (exercise.empty()) return {};
  auto ex = training::load_named_exercise(exercise);
  return ex ? std::string() : "--exercise " + exercise + ": " + ex.error();
}

void remove_old_score(const std::string& dir) {
  std::error_code ec;
  for (const char* f : {"score.json", "score.html"}) fs::remove(fs::path(dir) / f, ec);
}

std::string recorded_exercise(const std::string& recording_dir) {
  if (recording_dir.empty()) return {};
  std::ifstream f(fs::path(recording_dir) / "recording.json");
  if (!f) return {};
  auto j = nlohmann::json::parse(f, nullptr, false);
  if (!j.is_object() || !j.contains("exercise") || !j["exercise"].is_string()) return {};
  return j["exercise"].get<std::string>();
}

DriverScore score_after_run(const DriverScoreInput& in) {
  DriverScore r;
  try {
    training::ScoreOptions so;
    so.session = in.session;
    so.out_dir = in.out_dir;
    so.exercise = !in.exercise.empty() ? in.exercise : recorded_exercise(in.recording);
    so.compare = in.compare;
    so.read_frames = read_view_frames;  // frames.csv's one reader (frames_csv.h)
    if (!in.frames_csv.empty() && fs::exists(in.frames_csv)) so.frames_csv = in.frames_csv;
    if (!in.station.empty()) {
      auto g = sight_from_station(in.station);
      if (g) {
        so.sight = *g;
        so.sight_source = in.station;
      }
    }
    auto s = training::score_session(so);
    if (!s) {
      r.warning = "the session was not scored (the recording is kept): " + s.error();
      return r;
    }
    r.ok = true;
    std::string why = s->outcome.completion;  // "incomplete: ... ." -> "..."
    for (const char* p : {"incomplete: ", "finished: "})
      if (why.rfind(p, 0) == 0) why = why.substr(std::string(p).size());
    if (!why.empty() && why.back() == '.') why.pop_back();
    // Training modes 1-4: the expert's bur cut, so the score is the expert's cut's, not the student's.
    r.line = std::string(s->expert_cut() ? "score of the " + s->cut_label() + ", not the student's: " : "score: ") + fmt1(s->outcome.points) + " / " + fmt1(s->outcome.max_points) + " points (" + s->exercise_name + ")" +
             (s->outcome.complete ? ", finished (" : ", INCOMPLETE (") + why + "); " + std::to_string(s->feedback.size()) + " feedback messages; wrote " +
             s->report_html + ", " + s->summary_json;
    if (!s->log_warning.empty()) r.line += "\n  score: log warning: " + s->log_warning;
    for (std::size_t i = 1; i < s->comparison.size(); ++i) {  // [0] is this session
      const auto& c = s->comparison[i];
      r.line += "\n  beside it, a " + c.label + " (" + fmt1(c.duration_s) + " s, drilling " + fmt1(c.drilling_s) +
                " s): " + fmt1(c.points) + " / " + fmt1(c.max_points) + " points" + (c.complete ? "" : ", INCOMPLETE");
    }
    if (!s->comparison_warning.empty()) r.line += "\n  score: no comparison: " + s->comparison_warning;
    std::ostringstream h;
    h << "<p>" << (s->expert_cut() ? "The " + esc(s->cut_label()) + " (not the student's): " : std::string()) << "<b>" << esc(s->outcome.headline()) << "</b> on " << esc(s->exercise_title) << " ("
      << esc(s->outcome.completion) << "); target coverage " << fmt1(s->outcome.target_coverage_pct) << " %, forbidden "
      << fmt1(s->outcome.forbidden_mm3) << " mm&sup3;, " << s->feedback.size()
      << " feedback messages. Full report: <a href=\"score.html\">score.html</a> (summary: <a href=\"score.json\">score.json</a>).</p>";
    if (s->comparison.size() > 1) {
      h << "<table><tr><th>session</th><th>time</th><th>points</th><th>finished?</th></tr>";
      for (const auto& c : s->comparison)
        h << "<tr><td>" << esc(c.label) << "</td><td>" << fmt1(c.duration_s) << " s</td><td>" << fmt1(c.points) << " / "
          << fmt1(c.max_points) << "</td><td>" << esc(c.completion) << "</td></tr>";
      h << "</table>";
    }
    r.html = h.str();
  } catch (const std::exception& e) {
    r.warning = std::string("the session was not scored (the recording is kept): ") + e.what();
  }
  return r;
}

StoreOutcome store_after_score(const StoreTarget& target, const std::string& session, const std::string& report_dir,
                               const std::function<void(const std::string&)>& note) {
  StoreOutcome out;
  std::error_code ec;
  const fs::path dir = fs::is_directory(session, ec) ? fs::path(session) : fs::path(session).parent_path();
  const fs::path rep = report_dir.empty() ? dir : fs::path(report_dir);
  if (!fs::exists(rep / "score.json", ec)) {
    if (note) note("scoring " + session + " before storing it");
    training::ScoreOptions so;
    so.session = session;
    so.out_dir = report_dir;
    so.read_frames = read_view_frames;
    auto sc = training::score_session(so);
    if (!sc) {
      out.error = "scoring " + session + " for the store: " + sc.error() + " (the session folder is kept)";
      // A damaged or foreign log is bad input (2); a log that reads but cannot be scored, a failed job (1).
      const fs::path log = fs::is_directory(session, ec) ? fs::path(session) / "session.dlog" : fs::path(session);
      out.exit_code = haptics::read_session_log(log.string()) ? 1 : 2;
      return out;
    }
  }
  store::ImportOptions io;
  io.student = target.student;
  io.station = target.station_id;
  io.report_dir = report_dir;
  auto rec = store::record_from_session_dir(session, io);
  if (!rec) {
    out.error = rec.error();
    out.exit_code = 2;
    return out;
  }
  const bool local_only = target.station_db.empty();
  // One open of the store written to (this station's own store for a server): the
  // another-student / --move check, the write and the forward happen on it. A store
  // that is damaged, foreign or newer is bad input (2, as `db status` and `serve` say
  // for the same file); one that is locked or cannot be reached, a failed job (1).
  store::StoreOptions so;
  so.move = target.move;
  store::OpenFault fault = store::OpenFault::None;
  auto r = store::store_session(*rec, local_only ? target.db : target.station_db, local_only ? "" : target.db, so, &fault);
  if (!r) {
    out.error = "storing " + session + ": " + r.error() + " (the session folder " + dir.string() + " is kept)";
    out.exit_code = fault == store::OpenFault::Unavailable ? 1 : 2;
    return out;
  }
  out.warning = r->warning;
  std::ostringstream line;
  line << "session " << rec->key.substr(0, 12) << " of " << rec->student << " (" << rec->exercise << ", " << rec->points
       << " / " << rec->max_points << " points): " << (r->moved_from.empty() ? "" : "moved from student " + r->moved_from + "; ")
       << r->message;
  out.line = line.str();
  return out;
}

FinishOutcome finish_run(const DriverScoreInput* score, const StoreTarget& target, const std::string& session,
                         const std::string& report_dir, const std::function<void(const std::string&)>& note) {
  FinishOutcome f;
  if (score) {
    f.scored = true;
    f.score = score_after_run(*score);
  }
  if (!target.db.empty()) {
    f.stored = true;
    f.store = store_after_score(target, session, report_dir, note);
  }
  return f;
}

}  // namespace dentar::session
