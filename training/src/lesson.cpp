#include "dentar/training/lesson.h"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>
#include <signal.h>
#include <unistd.h>

#include <cerrno>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/exercise.h"

namespace dentar::training {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kMm = 1e-3;
constexpr double kDeg = M_PI / 180.0;

std::string hex16(std::uint64_t h) {
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h));
  return b;
}

// Field readers: each names `where` (file and field path) in its message.
struct Reader {
  std::string name;
  std::string err;
  bool fail(const std::string& field, const std::string& what) {
    if (err.empty()) err = name + ": " + field + " " + what;
    return false;
  }
  bool number(const json& o, const char* key, const std::string& path, double& out, bool required) {
    if (!o.contains(key)) return required ? fail(path + key, "is missing") : true;
    const json& v = o[key];
    if (!v.is_number()) return fail(path + key, "must be a number, got " + v.dump());
    out = v.get<double>();
    if (!std::isfinite(out)) return fail(path + key, "must be finite");
    return true;
  }
  bool string(const json& o, const char* key, const std::string& path, std::string& out, bool required) {
    if (!o.contains(key)) return required ? fail(path + key, "is missing") : true;
    if (!o[key].is_string()) return fail(path + key, "must be a string, got " + o[key].dump());
    out = o[key].get<std::string>();
    return true;
  }
  bool boolean(const json& o, const char* key, const std::string& path, bool& out) {
    if (!o.contains(key)) return true;
    if (!o[key].is_boolean()) return fail(path + key, "must be true or false, got " + o[key].dump());
    out = o[key].get<bool>();
    return true;
  }
  bool object(const json& o, const char* key, const std::string& path, const json*& out) {
    out = nullptr;
    if (!o.contains(key)) return true;
    if (!o[key].is_object()) return fail(path + key, "must be an object");
    out = &o[key];
    return true;
  }
};

std::string tooth_kind(const std::string& tooth_json) {
  json j = json::parse(tooth_json, nullptr, false);
  if (j.is_object() && j.contains("kind") && j["kind"].is_string()) return j["kind"].get<std::string>();
  return "";
}

// The recording's setup and records, refusing any damage.
struct Recording {
  haptics::SessionLog log;
  haptics::SessionSetup setup;
};
Result<Recording> read_recording(const std::string& path) {
  if (!fs::exists(path)) return Error{path + ": no such recording (give a session .dlog or a folder holding session.dlog)"};
  auto log = haptics::read_session_log(path);
  if (!log) return Error{log.error()};
  if (!log->warning.empty())
    return Error{log->warning + " (the recording is damaged; record it again, or repair it by truncating it to its " +
                 std::to_string(log->good_bytes) + " good bytes)"};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{path + ": " + setup.error()};
  Recording r{std::move(log).value(), std::move(setup).value()};
  return r;
}

bool copy_file_exact(const std::string& from, const std::string& to, std::string& err) {
  std::error_code ec;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
  if (ec) err = "cannot copy " + from + " to " + to + ": " + ec.message();
  return !ec;
}

}  // namespace

Result<Lesson> parse_lesson(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return Error{name + ": not valid JSON (a truncated or corrupt lesson; make it again)"};
  if (!j.is_object()) return Error{name + ": a lesson must be a JSON object"};
  Reader rd{name, ""};
  Lesson l;
  std::string format;
  double version = 0;
  if (!rd.string(j, "format", "", format, true)) return Error{rd.err};
  if (format != "dentar-lesson") return Error{name + ": format is '" + format + "', not 'dentar-lesson'"};
  if (!rd.number(j, "version", "", version, true)) return Error{rd.err};
  if (version != kLessonVersion)
    return Error{name + ": version " + json(version).dump() + " is not supported (this build reads version " +
                 std::to_string(kLessonVersion) + ")"};
  l.version = kLessonVersion;
  const json* rec = nullptr;
  if (!rd.string(j, "exercise", "", l.exercise, true) || !rd.string(j, "title", "", l.title, false) ||
      !rd.string(j, "source", "", l.source, false) || !rd.object(j, "recording", "", rec))
    return Error{rd.err};
  if (l.exercise.empty()) return Error{name + ": exercise is empty"};
  if (!rec) return Error{name + ": recording is missing"};
  std::string hash;
  double steps = 0;
  if (!rd.string(*rec, "file", "recording.", l.recording, true) || !rd.string(*rec, "hash", "recording.", hash, true) ||
      !rd.number(*rec, "steps", "recording.", steps, true) ||
      !rd.number(*rec, "duration_s", "recording.", l.duration_s, true))
    return Error{rd.err};
  if (l.recording.empty() || l.recording.find('/') != std::string::npos || l.recording == "..")
    return Error{name + ": recording.file '" + l.recording + "' must be a file name inside the lesson folder"};
  char* end = nullptr;
  l.recording_hash = std::strtoull(hash.c_str(), &end, 16);
  if (hash.size() != 16 || !end || *end) return Error{name + ": recording.hash must be 16 hex digits, got '" + hash + "'"};
  if (steps < 2 || steps != std::floor(steps) || steps > 1e12)
    return Error{name + ": recording.steps = " + json(steps).dump() + " must be a whole number >= 2"};
  l.recording_steps = static_cast<std::uint64_t>(steps);
  if (l.duration_s <= 0) return Error{name + ": recording.duration_s must be > 0"};
  if (!rec->contains("tooth") || !(*rec)["tooth"].is_object() || tooth_kind((*rec)["tooth"].dump()).empty())
    return Error{name + ": recording.tooth must be an object with a \"kind\""};
  l.tooth_json = (*rec)["tooth"].dump();

  // The modes' options (all optional: the defaults of haptics/guidance.h).
  haptics::TrainingParams& p = l.params;
  const json* modes = nullptr;
  if (!rd.object(j, "modes", "", modes)) return Error{rd.err};
  if (modes) {
    const json *g = nullptr, *t = nullptr;
    if (!rd.object(*modes, "guidance", "modes.", g) || !rd.object(*modes, "tolerance", "modes.", t)) return Error{rd.err};
    double k = p.guidance.k_N_per_m, e1 = p.guidance.eps1_m / kMm, e2 = p.guidance.eps2_m / kMm,
           d = p.guidance.damping_N_s_per_m;
    if (g && (!rd.number(*g, "k_N_per_m", "modes.guidance.", k, false) ||
              !rd.number(*g, "eps1_mm", "modes.guidance.", e1, false) ||
              !rd.number(*g, "eps2_mm", "modes.guidance.", e2, false) ||
              !rd.number(*g, "damping_N_s_per_m", "modes.guidance.", d, false) ||
              !rd.boolean(*g, "quadratic_core", "modes.guidance.", p.guidance.quadratic_core) ||
              !rd.boolean(*g, "across_path_only", "modes.guidance.", p.guidance.across_path_only) ||
              !rd.boolean(*g, "as_needed", "modes.guidance.", p.guidance.as_needed) ||
              !rd.number(*g, "fade", "modes.guidance.", p.guidance.fade, false) ||
              !rd.number(*g, "amplify", "modes.guidance.", p.guidance.amplify, false)))
      return Error{rd.err};
    p.guidance.k_N_per_m = k;
    p.guidance.eps1_m = e1 * kMm;
    p.guidance.eps2_m = e2 * kMm;
    p.guidance.damping_N_s_per_m = d;
    double eps = p.tolerance.eps_m / kMm;
    if (t && !rd.number(*t, "eps_mm", "modes.tolerance.", eps, false)) return Error{rd.err};
    p.tolerance.eps_m = eps * kMm;
    if (t && t->contains("theta_deg")) {
      const json& th = (*t)["theta_deg"];
      if (!th.is_array() || th.size() != 3)
        return Error{name + ": modes.tolerance.theta_deg must be 3 numbers (degrees about the tool's x, y, z)"};
      for (std::size_t i = 0; i < 3; ++i) {
        if (!th[i].is_number() || !std::isfinite(th[i].get<double>()))
          return Error{name + ": modes.tolerance.theta_deg[" + std::to_string(i) + "] must be a number"};
        p.tolerance.theta_rad[i] = th[i].get<double>() * kDeg;
      }
    }
    if (!rd.boolean(*modes, "conditional_replay", "modes.", p.conditional_replay) ||
        !rd.number(*modes, "speed", "modes.", p.speed, false) || !rd.number(*modes, "ramp_s", "modes.", p.ramp_s, false))
      return Error{rd.err};
  }
  if (std::string v = p.validate(); !v.empty()) return Error{name + ": modes: " + v};

  if (j.contains("annotations")) {
    const json& a = j["annotations"];
    if (!a.is_array()) return Error{name + ": annotations must be an array"};
    if (a.size() > 10000) return Error{name + ": annotations: " + std::to_string(a.size()) + " is more than 10000"};
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::string at = "annotations[" + std::to_string(i) + "].";
      if (!a[i].is_object()) return Error{name + ": annotations[" + std::to_string(i) + "] must be an object"};
      Annotation n;
      double step = -1;
      const bool has_t = a[i].contains("time_s"), has_s = a[i].contains("step");
      if (has_t == has_s) return Error{name + ": " + at + " needs exactly one of time_s and step"};
      if (!rd.number(a[i], "time_s", at, n.time_s, false) || !rd.number(a[i], "step", at, step, false) ||
          !rd.string(a[i], "text", at, n.text, false) || !rd.number(a[i], "pause_s", at, n.pause_s, false))
        return Error{rd.err};
      if (has_t && n.time_s < 0) return Error{name + ": " + at + "time_s = " + json(n.time_s).dump() + " must be >= 0"};
      if (has_s) {
        if (step < 0 || step != std::floor(step) || step > 1e15)
          return Error{name + ": " + at + "step = " + json(step).dump() + " must be a whole number >= 0"};
        n.step = static_cast<std::int64_t>(step);
      }
      if (n.pause_s < 0 || n.pause_s > 600)
        return Error{name + ": " + at + "pause_s = " + json(n.pause_s).dump() + " must be in [0, 600] s"};
      if (n.text.empty() && n.pause_s == 0) return Error{name + ": " + at + " has neither text nor pause_s"};
      if (has_t && n.time_s > l.duration_s)
        return Error{name + ": " + at + "time_s = " + json(n.time_s).dump() + " s is past the end of the recording (" +
                     json(l.duration_s).dump() + " s)"};
      l.annotations.push_back(n);
    }
  }
  return l;
}

std::string lesson_json(const Lesson& l) {
  const auto& g = l.params.guidance;
  const auto& t = l.params.tolerance;
  json a = json::array();
  for (const Annotation& n : l.annotations) {
    json o;
    if (n.step >= 0)
      o["step"] = n.step;
    else
      o["time_s"] = n.time_s;
    if (!n.text.empty()) o["text"] = n.text;
    if (n.pause_s > 0) o["pause_s"] = n.pause_s;
    a.push_back(o);
  }
  json j = {
      {"format", "dentar-lesson"},
      {"version", kLessonVersion},
      {"exercise", l.exercise},
      {"title", l.title},
      {"source", l.source},
      {"recording",
       {{"file", l.recording},
        {"hash", hex16(l.recording_hash)},
        {"steps", l.recording_steps},
        {"duration_s", l.duration_s},
        {"tooth", json::parse(l.tooth_json, nullptr, false)}}},
      {"modes",
       {{"guidance",
         {{"k_N_per_m", g.k_N_per_m}, {"eps1_mm", g.eps1_m / kMm}, {"eps2_mm", g.eps2_m / kMm},
          {"damping_N_s_per_m", g.damping_N_s_per_m}, {"quadratic_core", g.quadratic_core},
          {"across_path_only", g.across_path_only}, {"as_needed", g.as_needed}, {"fade", g.fade},
          {"amplify", g.amplify}}},
        {"tolerance",
         {{"eps_mm", t.eps_m / kMm}, {"theta_deg", {t.theta_rad[0] / kDeg, t.theta_rad[1] / kDeg, t.theta_rad[2] / kDeg}}}},
        {"conditional_replay", l.params.conditional_replay},
        {"speed", l.params.speed},
        {"ramp_s", l.params.ramp_s}}},
      {"annotations", a}};
  return j.dump(1) + "\n";
}

Result<Lesson> load_lesson(const std::string& path_in) {
  std::string dir = path_in, file = path_in;
  if (fs::is_directory(path_in))
    file = (fs::path(path_in) / kLessonFile).string();
  else
    dir = fs::path(path_in).parent_path().string();
  if (dir.empty()) dir = ".";
  if (!fs::exists(file))
    return Error{file + ": no such lesson (make one with `dentar lesson make`, or `dentar lesson builtin`)"};
  std::ifstream in(file, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  if (!in.good() && !in.eof()) return Error{file + ": cannot read"};
  auto l = parse_lesson(ss.str(), file);
  if (!l) return l;
  l->path = dir;
  const std::string rp = l->recording_path();
  auto rec = read_recording(rp);
  if (!rec) return Error{file + ": recording.file: " + rec.error()};
  auto track = haptics::ExpertTrack::from_records(rec->log.records, rec->setup.engine.T_tooth_dev,
                                                  rec->setup.engine.T_sty_tip, rp);
  if (!track) return Error{file + ": recording.file: " + track.error()};
  if (track->content_hash() != l->recording_hash)
    return Error{file + ": recording.hash: " + rp + " has content hash " + hex16(track->content_hash()) +
                 ", the lesson was made from " + hex16(l->recording_hash) +
                 " (the recording was replaced or changed; make the lesson again)"};
  if (rec->log.records.size() != l->recording_steps)
    return Error{file + ": recording.steps: the lesson says " + std::to_string(l->recording_steps) + ", " + rp +
                 " holds " + std::to_string(rec->log.records.size())};
  if (tooth_kind(rec->setup.tooth_json) != tooth_kind(l->tooth_json))
    return Error{file + ": recording.tooth: the lesson says " + l->tooth_json + ", the recording is of " +
                 rec->setup.tooth_json};
  auto ex = load_named_exercise(l->exercise);
  if (!ex) return Error{file + ": exercise: " + ex.error()};
  if (tooth_kind(ex->tooth_json) != tooth_kind(l->tooth_json))
    return Error{file + ": exercise: '" + l->exercise + "' is for tooth kind '" + tooth_kind(ex->tooth_json) +
                 "', the lesson's recording is of a '" + tooth_kind(l->tooth_json) + "'" +
                 " (a lesson for another tooth; pick the exercise the recording was made for)"};
  // Steps into times.
  const auto& recs = rec->log.records;
  const double t0 = recs.front().time_s;
  for (std::size_t i = 0; i < l->annotations.size(); ++i) {
    Annotation& n = l->annotations[i];
    if (n.step >= 0) {
      auto it = std::lower_bound(recs.begin(), recs.end(), static_cast<std::uint64_t>(n.step),
                                 [](const haptics::StepRecord& r, std::uint64_t s) { return r.step < s; });
      if (it == recs.end() || it->step != static_cast<std::uint64_t>(n.step))
        return Error{file + ": annotations[" + std::to_string(i) + "].step = " + std::to_string(n.step) +
                     " is not in the recording (steps " + std::to_string(recs.front().step) + ".." +
                     std::to_string(recs.back().step) + ")"};
      n.time_s = it->time_s - t0;
    }
    if (n.time_s > track->duration_s())
      return Error{file + ": annotations[" + std::to_string(i) + "] at " + json(n.time_s).dump() +
                   " s is past the end of the recording (" + json(track->duration_s()).dump() + " s)"};
  }
  std::stable_sort(l->annotations.begin(), l->annotations.end(),
                   [](const Annotation& a, const Annotation& b) { return a.time_s < b.time_s; });
  return l;
}

Result<Lesson> make_lesson(const std::string& recording_in, const std::string& out_dir, const LessonMakeOptions& opt) {
  std::string recording = recording_in;
  if (fs::is_directory(recording_in)) {
    recording = (fs::path(recording_in) / "session.dlog").string();
    if (!fs::exists(recording))
      return Error{recording_in + ": the folder holds no session.dlog (give the session log itself)"};
  }
  if (opt.exercise.empty()) return Error{"--exercise is required (a built-in exercise name or an exercise file)"};
  auto ex = load_named_exercise(opt.exercise);
  if (!ex) return Error{"--exercise: " + ex.error()};
  if (fs::exists(out_dir)) return Error{out_dir + ": already exists (lesson make writes a new folder; remove it or pick another name)"};
  auto rec = read_recording(recording);
  if (!rec) return Error{rec.error()};
  if (tooth_kind(rec->setup.tooth_json) != tooth_kind(ex->tooth_json))
    return Error{recording + ": the recording is of tooth kind '" + tooth_kind(rec->setup.tooth_json) + "' (" +
                 rec->setup.tooth_json + "), exercise '" + ex->name + "' is for '" + tooth_kind(ex->tooth_json) + "'" +
                 " (pick the exercise the recording was made for)"};
  auto track = haptics::ExpertTrack::from_records(rec->log.records, rec->setup.engine.T_tooth_dev,
                                                  rec->setup.engine.T_sty_tip, recording);
  if (!track) return Error{track.error()};
  if (std::string v = opt.params.validate(); !v.empty()) return Error{"lesson options: " + v};
  Lesson l;
  l.exercise = opt.exercise;
  l.title = opt.title.empty() ? ex->title : opt.title;
  l.source = opt.source.empty() ? fs::absolute(recording).lexically_normal().string() : opt.source;
  l.tooth_json = rec->setup.tooth_json;
  l.recording = kLessonRecording;
  l.recording_hash = track->content_hash();
  l.recording_steps = rec->log.records.size();
  l.duration_s = track->duration_s();
  l.params = opt.params;
  l.params.mode = haptics::TrainingModeKind::kNone;
  l.params.expert_file.clear();
  // A generated expert's step labels become text annotations.
  const fs::path steps_json = fs::path(recording).parent_path() / "steps.json";
  if (opt.step_annotations && fs::exists(steps_json)) {
    std::ifstream in(steps_json);
    json sj = json::parse(in, nullptr, false);
    if (sj.is_object() && sj.contains("step_order") && sj.contains("step_start_s") && sj["step_order"].is_array() &&
        sj["step_start_s"].is_array() && sj["step_order"].size() == sj["step_start_s"].size()) {
      for (std::size_t k = 0; k < sj["step_order"].size(); ++k) {
        if (!sj["step_order"][k].is_number_integer() || !sj["step_start_s"][k].is_number()) continue;
        const int s = sj["step_order"][k].get<int>();
        const double t = sj["step_start_s"][k].get<double>();
        if (s < 0 || s >= static_cast<int>(ex->steps.size()) || !(t >= 0) || t > l.duration_s) continue;
        Annotation n;
        n.time_s = t;
        n.text = "Step " + std::to_string(k + 1) + ": " + ex->steps[static_cast<std::size_t>(s)].name;
        l.annotations.push_back(n);
      }
    }
  }
  for (std::size_t i = 0; i < opt.annotations.size(); ++i) {
    const Annotation& n = opt.annotations[i];
    if (n.step < 0 && (n.time_s < 0 || n.time_s > l.duration_s))
      return Error{"annotation " + std::to_string(i + 1) + " at " + json(n.time_s).dump() +
                   " s is outside the recording (0.." + json(l.duration_s).dump() + " s)"};
    l.annotations.push_back(n);
  }
  // Write beside OUT, check by reading back, then rename: nothing is half written.
  const fs::path out = fs::absolute(out_dir).lexically_normal();
  std::error_code ec;
  if (!out.parent_path().empty()) fs::create_directories(out.parent_path(), ec);
  const std::string part = out.filename().string() + ".part";
  // A `lesson make` that was killed leaves OUT.part<pid>: removed here once that process is gone.
  for (fs::directory_iterator it(out.parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= part.size() || n.compare(0, part.size(), part) != 0) continue;
    const std::string digits = n.substr(part.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(digits));
    if (pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH) {
      std::error_code e2;
      fs::remove_all(it->path(), e2);
    }
  }
  ec.clear();
  const fs::path tmp = out.parent_path() / (part + std::to_string(::getpid()));
  fs::remove_all(tmp, ec);
  auto cleanup = [&] { std::error_code e2; fs::remove_all(tmp, e2); };
  if (!fs::create_directories(tmp, ec) || ec) return Error{tmp.string() + ": cannot create: " + ec.message()};
  std::string err;
  if (!copy_file_exact(recording, (tmp / kLessonRecording).string(), err)) {
    cleanup();
    return Error{err};
  }
  {
    std::ofstream o(tmp / kLessonFile, std::ios::binary);
    o << lesson_json(l);
    o.close();
    if (!o) {
      cleanup();
      return Error{(tmp / kLessonFile).string() + ": cannot write"};
    }
  }
  auto back = load_lesson(tmp.string());
  if (!back) {
    cleanup();
    return Error{"the lesson does not read back: " + back.error()};
  }
  fs::rename(tmp, out, ec);
  if (ec) {
    cleanup();
    return Error{"cannot rename " + tmp.string() + " to " + out.string() + ": " + ec.message()};
  }
  back->path = out.string();
  return back;
}

Result<Lesson> make_generated_lesson(const std::string& exercise, const std::string& out_dir, std::uint64_t seed) {
  auto ex = load_named_exercise(exercise);
  if (!ex) return Error{"--exercise: " + ex.error()};
  // Scratch under $TMPDIR (not a fixed /tmp), removed on every return below.
  std::error_code tec;
  const fs::path tmp_root = fs::temp_directory_path(tec);
  const fs::path tmp_dir = tec ? fs::path("/tmp") : tmp_root;
  std::string tmpl = (tmp_dir / "dentar_lesson_XXXXXX").string();
  const char* scratch = ::mkdtemp(tmpl.data());
  if (!scratch)
    return Error{"cannot create a scratch folder in " + tmp_dir.string() + " (set TMPDIR to a writable folder)"};
  const std::string sdir = scratch;
  auto cleanup = [&] { std::error_code e; fs::remove_all(sdir, e); };
  CohortOptions co;
  co.experts = 1;
  co.novices = 0;
  co.trials = 1;
  co.seed = seed;
  auto trials = generate_cohort(*ex, co, sdir + "/cohort");
  if (!trials || trials->empty()) {
    cleanup();
    return Error{"generating the expert for '" + exercise + "': " + (trials ? "no session" : trials.error())};
  }
  LessonMakeOptions mo;
  mo.exercise = exercise;
  mo.title = ex->title + " (generated expert)";
  mo.source = "generated: cohort generator v" + std::to_string(kCohortGeneratorVersion) + ", expert E1, seed " +
              std::to_string(seed) + ", voxel " + json(co.voxel_mm).dump() + " mm";
  auto l = make_lesson(trials->front().session_path, out_dir, mo);
  cleanup();
  return l;
}

Result<std::string> resolve_lesson_path(const std::string& lesson) {
  if (lesson.rfind("builtin:", 0) != 0) return lesson;
  const std::string name = lesson.substr(8);
  std::string cache;
  if (const char* d = std::getenv("DENTAR_CACHE_DIR"); d && *d)
    cache = d;
  else if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    cache = std::string(x) + "/dentar";
  else if (const char* h = std::getenv("HOME"); h && *h)
    cache = std::string(h) + "/.cache/dentar";
  if (cache.empty()) return Error{lesson + ": no cache folder (set DENTAR_CACHE_DIR, or make it with `dentar lesson builtin`)"};
  const std::string dir = cache + "/lessons/cohort-v" + std::to_string(kCohortGeneratorVersion) + "/" + name;
  if (fs::exists(fs::path(dir) / kLessonFile)) return dir;
  auto made = make_generated_lesson(name, dir, 1);
  // Another process may have made it meanwhile: its folder wins.
  if (!made && !fs::exists(fs::path(dir) / kLessonFile)) return Error{lesson + ": " + made.error()};
  return dir;
}

std::string describe_lesson(const Lesson& l) {
  std::ostringstream os;
  const auto& g = l.params.guidance;
  const auto& t = l.params.tolerance;
  os << "lesson:     " << l.path << "\n"
     << "title:      " << l.title << "\n"
     << "exercise:   " << l.exercise << "\n"
     << "tooth:      " << l.tooth_json << "\n"
     << "source:     " << l.source << "\n";
  char b[256];
  std::snprintf(b, sizeof b, "recording:  %s, %llu haptic steps, %.1f s, content hash %s\n", l.recording.c_str(),
                static_cast<unsigned long long>(l.recording_steps), l.duration_s, hex16(l.recording_hash).c_str());
  os << b;
  std::snprintf(b, sizeof b,
                "mode 2:     guidance k %.0f N/m, eps1 %.2f mm, eps2 %.1f mm, damping %.2f N s/m, %s core%s%s\n",
                g.k_N_per_m, g.eps1_m / kMm, g.eps2_m / kMm, g.damping_N_s_per_m,
                g.quadratic_core ? "quadratic" : "linear", g.across_path_only ? ", across the path only" : "",
                g.as_needed ? ", as needed" : "");
  os << b;
  std::snprintf(b, sizeof b, "mode 3:     conditional replay %s, within %.1f mm and %.0f/%.0f/%.0f deg\n",
                l.params.conditional_replay ? "on" : "off", t.eps_m / kMm, t.theta_rad[0] / kDeg,
                t.theta_rad[1] / kDeg, t.theta_rad[2] / kDeg);
  os << b;
  std::snprintf(b, sizeof b, "all modes:  expert speed %.2f, force ramp %.2f s\n", l.params.speed, l.params.ramp_s);
  os << b;
  os << "annotations: " << l.annotations.size() << "\n";
  for (const Annotation& n : l.annotations) {
    std::snprintf(b, sizeof b, "  %8.2f s  ", n.time_s);
    os << b;
    if (n.pause_s > 0) {
      std::snprintf(b, sizeof b, "[pause %.1f s] ", n.pause_s);
      os << b;
    }
    os << n.text << "\n";
  }
  return os.str();
}

Result<Annotation> parse_annotation_arg(const std::string& arg, bool pause, const std::string& option) {
  Annotation n;
  const auto colon = arg.find(':');
  std::string at = arg.substr(0, colon), rest = colon == std::string::npos ? "" : arg.substr(colon + 1);
  auto bad = [&](const std::string& why) {
    return Error{option + " '" + arg + "': " + why +
                 (pause ? " (use TIME_S:SECONDS or @STEP:SECONDS)" : " (use TIME_S:TEXT or @STEP:TEXT)")};
  };
  char* end = nullptr;
  if (!at.empty() && at[0] == '@') {
    const long long s = std::strtoll(at.c_str() + 1, &end, 10);
    if (at.size() < 2 || *end || s < 0) return bad("the step must be a whole number >= 0");
    n.step = s;
  } else {
    n.time_s = std::strtod(at.c_str(), &end);
    if (at.empty() || *end || !std::isfinite(n.time_s) || n.time_s < 0) return bad("the time must be a number of seconds >= 0");
  }
  if (pause) {
    n.pause_s = rest.empty() ? 2.0 : std::strtod(rest.c_str(), &end);
    if (!rest.empty() && *end) return bad("the pause must be a number of seconds");
    if (!std::isfinite(n.pause_s) || n.pause_s <= 0 || n.pause_s > 600) return bad("the pause must be in (0, 600] s");
    n.text = "pause";
  } else {
    if (rest.empty()) return bad("the text is empty");
    n.text = rest;
  }
  return n;
}

int active_note(const std::vector<Annotation>& annotations, double expert_time_s, double show_s) {
  int found = -1;
  for (std::size_t i = 0; i < annotations.size() && annotations[i].time_s <= expert_time_s; ++i)
    if (!annotations[i].text.empty() && expert_time_s < annotations[i].time_s + show_s) found = static_cast<int>(i);
  return found;
}

}  // namespace dentar::training
