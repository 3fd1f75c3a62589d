#include "dentar/store/record.h"

#include <openssl/evp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dentar::store {
namespace fs = std::filesystem;
using nlohmann::json;

std::string validate_code(const std::string& what, const std::string& code) {
  if (code.empty()) return "";
  if (code.size() > 64) return what + " '" + code.substr(0, 64) + "...': longer than 64 characters";
  if (code[0] == '.') return what + " '" + code + "': must not start with '.'";
  for (unsigned char c : code)
    if (!(std::isalnum(c) || c == '.' || c == '_' || c == '@' || c == '-'))
      return what + " '" + code + "': only letters, digits and . _ @ - are allowed";
  return "";
}

std::string utc_now_iso() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

namespace {

std::string to_hex(const unsigned char* d, std::size_t n) {
  static const char* k = "0123456789abcdef";
  std::string s(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    s[2 * i] = k[d[i] >> 4];
    s[2 * i + 1] = k[d[i] & 15];
  }
  return s;
}

struct Sha {
  EVP_MD_CTX* c = EVP_MD_CTX_new();
  Sha() { EVP_DigestInit_ex(c, EVP_sha256(), nullptr); }
  ~Sha() { EVP_MD_CTX_free(c); }
  void add(const void* p, std::size_t n) { EVP_DigestUpdate(c, p, n); }
  std::string hex() {
    unsigned char d[32];
    unsigned int n = 0;
    EVP_DigestFinal_ex(c, d, &n);
    return to_hex(d, n);
  }
};

Status hash_into(Sha& h, const std::string& path, std::int64_t* bytes) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return Error{path + ": cannot read"};
  std::vector<char> buf(1 << 16);
  std::int64_t total = 0;
  while (f) {
    f.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto n = f.gcount();
    if (n > 0) h.add(buf.data(), static_cast<std::size_t>(n));
    total += n;
  }
  if (f.bad()) return Error{path + ": read error"};
  if (bytes) *bytes = total;
  return {};
}

std::string unit_of(const std::string& name) {
  for (const char* u : {"_mm3", "_mm", "_s", "_N", "_pct", "_deg"}) {
    const std::string s = u;
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) return s.substr(1);
  }
  return "";
}

// Numeric leaves of score.json's outcome and process as metrics; arrays of
// named objects use the name as the path segment.
void flatten(const json& j, const std::string& prefix, std::vector<Metric>& out) {
  if (j.is_number()) {
    const double v = j.get<double>();
    if (std::isfinite(v)) {
      const std::string leaf = prefix.substr(prefix.rfind('.') + 1);
      out.push_back({prefix, v, unit_of(leaf)});
    }
  } else if (j.is_boolean()) {
    out.push_back({prefix, j.get<bool>() ? 1.0 : 0.0, "bool"});
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) flatten(it.value(), prefix + "." + it.key(), out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      const json& e = j[i];
      const std::string seg = e.is_object() && e.contains("name") && e["name"].is_string() ? e["name"].get<std::string>()
                                                                                          : std::to_string(i);
      flatten(e, prefix + "." + seg, out);
    }
  }
}

std::array<double, 3> vec3(const json& j) {
  std::array<double, 3> v{};
  if (j.is_array() && j.size() == 3)
    for (std::size_t i = 0; i < 3; ++i) v[i] = j[i].is_number() ? j[i].get<double>() : 0.0;
  return v;
}

double num(const json& j, const char* k) {
  return j.is_object() && j.contains(k) && j[k].is_number() ? j[k].get<double>() : 0.0;
}

std::string str_of(const json& j, const char* k) {
  return j.is_object() && j.contains(k) && j[k].is_string() ? j[k].get<std::string>() : "";
}

std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

std::string sha256_hex(std::string_view bytes) {
  Sha h;
  h.add(bytes.data(), bytes.size());
  return h.hex();
}

Result<std::string> sha256_file(const std::string& path) {
  Sha h;
  if (auto s = hash_into(h, path, nullptr); !s) return Error{s.error()};
  return h.hex();
}

json to_json(const SessionRecord& r) {
  json j = {{"format", "dentar-stored-session"}, {"version", 1}, {"key", r.key}, {"student", r.student},
            {"station", r.station}, {"exercise", r.exercise}, {"exercise_title", r.exercise_title},
            {"started_utc", r.started_utc}, {"points", r.points}, {"max_points", r.max_points},
            {"coverage_pct", r.coverage_pct}, {"overprep_mm3", r.overprep_mm3}, {"forbidden_mm3", r.forbidden_mm3},
            {"removed_mm3", r.removed_mm3}, {"pulp_exposed", r.pulp_exposed}, {"perforation", r.perforation},
            {"duration_s", r.duration_s}, {"drilling_s", r.drilling_s}, {"path_mm", r.path_mm},
            {"excessive_force_s", r.excessive_force_s}, {"log_path", r.log_path}, {"log_sha256", r.log_sha256},
            {"log_bytes", r.log_bytes}, {"log_warning", r.log_warning}, {"recording_path", r.recording_path},
            {"recording_sha256", r.recording_sha256}, {"report_dir", r.report_dir}, {"score_json", r.score_json},
            {"score_html", r.score_html}};
  if (!r.stored_utc.empty()) j["stored_utc"] = r.stored_utc;
  j["metrics"] = json::array();
  for (const auto& m : r.metrics) j["metrics"].push_back({{"name", m.name}, {"value", m.value}, {"unit", m.unit}});
  j["feedback"] = json::array();
  for (const auto& f : r.feedback) j["feedback"].push_back({{"step", f.step}, {"kind", f.kind}, {"text", f.text}});
  j["steps"] = json::array();
  for (const auto& s : r.steps) {
    json sj = {{"name", s.name}, {"start_s", s.start_s}, {"end_s", s.end_s}, {"drilling_s", s.drilling_s},
               {"path_mm", s.path_mm}, {"removed_mm3", s.removed_mm3}, {"force_mean_N", s.force_N},
               {"force_sd_N", s.force_sd_N}};
    if (s.has_expert) {
      sj["expert_force_mean_N"] = s.expert_force_N;
      sj["expert_force_sd_N"] = s.expert_sd_N;
    }
    j["steps"].push_back(sj);
  }
  return j;
}

namespace {

struct Reader {
  const json& j;
  std::string err;
  std::string str(const char* k, bool required = false) {
    if (!j.contains(k)) {
      if (required && err.empty()) err = std::string(k) + ": missing";
      return "";
    }
    if (!j[k].is_string()) {
      if (err.empty()) err = std::string(k) + ": must be a string";
      return "";
    }
    return j[k].get<std::string>();
  }
  double number(const char* k) {
    if (!j.contains(k) || j[k].is_null()) return 0;
    if (!j[k].is_number() || !std::isfinite(j[k].get<double>())) {
      if (err.empty()) err = std::string(k) + ": must be a finite number";
      return 0;
    }
    return j[k].get<double>();
  }
  bool boolean(const char* k) {
    if (!j.contains(k)) return false;
    if (!j[k].is_boolean()) {
      if (err.empty()) err = std::string(k) + ": must be true or false";
      return false;
    }
    return j[k].get<bool>();
  }
};

}  // namespace

Result<SessionRecord> record_from_json(const json& j) {
  if (!j.is_object()) return Error{"stored session: not a JSON object"};
  if (str_of(j, "format") != "dentar-stored-session")
    return Error{"stored session: format must be \"dentar-stored-session\""};
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<long long>() != 1)
    return Error{"stored session: version must be 1"};
  Reader rd{j, {}};
  SessionRecord r;
  r.key = rd.str("key", true);
  r.student = rd.str("student", true);
  r.station = rd.str("station", true);
  r.exercise = rd.str("exercise", true);
  r.exercise_title = rd.str("exercise_title");
  r.started_utc = rd.str("started_utc", true);
  r.points = rd.number("points");
  r.max_points = rd.number("max_points");
  r.coverage_pct = rd.number("coverage_pct");
  r.overprep_mm3 = rd.number("overprep_mm3");
  r.forbidden_mm3 = rd.number("forbidden_mm3");
  r.removed_mm3 = rd.number("removed_mm3");
  r.pulp_exposed = rd.boolean("pulp_exposed");
  r.perforation = rd.boolean("perforation");
  r.duration_s = rd.number("duration_s");
  r.drilling_s = rd.number("drilling_s");
  r.path_mm = rd.number("path_mm");
  r.excessive_force_s = rd.number("excessive_force_s");
  r.log_path = rd.str("log_path");
  r.log_sha256 = rd.str("log_sha256");
  r.log_bytes = static_cast<std::int64_t>(rd.number("log_bytes"));
  r.log_warning = rd.str("log_warning");
  r.recording_path = rd.str("recording_path");
  r.recording_sha256 = rd.str("recording_sha256");
  r.report_dir = rd.str("report_dir");
  r.score_json = rd.str("score_json");
  r.score_html = rd.str("score_html");
  r.stored_utc = rd.str("stored_utc");
  if (!rd.err.empty()) return Error{"stored session: " + rd.err};
  for (const auto& [what, v] : {std::pair{"student", r.student}, std::pair{"station", r.station}}) {
    if (v.empty()) return Error{std::string("stored session: ") + what + ": empty"};
    if (auto e = validate_code(what, v); !e.empty()) return Error{"stored session: " + e};
  }
  if (r.key.empty() || r.key.size() > 128) return Error{"stored session: key: must be 1-128 characters"};
  if (r.exercise.empty()) return Error{"stored session: exercise: empty"};
  if (auto e = validate_code("exercise", r.exercise); !e.empty()) return Error{"stored session: " + e};
  auto arr = [&](const char* k) -> const json* {
    if (!j.contains(k)) return nullptr;
    return j[k].is_array() ? &j[k] : nullptr;
  };
  if (const json* a = arr("metrics"))
    for (const auto& m : *a) {
      if (!m.is_object()) return Error{"stored session: metrics: entries must be objects"};
      Reader mr{m, {}};
      Metric x{mr.str("name", true), mr.number("value"), mr.str("unit")};
      if (!mr.err.empty()) return Error{"stored session: metrics: " + mr.err};
      r.metrics.push_back(x);
    }
  if (const json* a = arr("feedback"))
    for (const auto& f : *a) {
      if (!f.is_object()) return Error{"stored session: feedback: entries must be objects"};
      Reader fr{f, {}};
      FeedbackItem x{fr.str("step"), fr.str("kind", true), fr.str("text", true)};
      if (!fr.err.empty()) return Error{"stored session: feedback: " + fr.err};
      r.feedback.push_back(x);
    }
  if (const json* a = arr("steps"))
    for (const auto& s : *a) {
      if (!s.is_object()) return Error{"stored session: steps: entries must be objects"};
      Reader sr{s, {}};
      StepScore x;
      x.name = sr.str("name", true);
      x.start_s = sr.number("start_s");
      x.end_s = sr.number("end_s");
      x.drilling_s = sr.number("drilling_s");
      x.path_mm = sr.number("path_mm");
      x.removed_mm3 = sr.number("removed_mm3");
      if (!sr.err.empty()) return Error{"stored session: steps: " + sr.err};
      x.force_N = vec3(s.value("force_mean_N", json()));
      x.force_sd_N = vec3(s.value("force_sd_N", json()));
      x.has_expert = s.contains("expert_force_mean_N");
      x.expert_force_N = vec3(s.value("expert_force_mean_N", json()));
      x.expert_sd_N = vec3(s.value("expert_force_sd_N", json()));
      r.steps.push_back(x);
    }
  return r;
}

Result<SessionRecord> record_from_session_dir(const std::string& path, const ImportOptions& opt) {
  if (opt.student.empty()) return Error{"no student given: pass --student CODE (who did this session)"};
  if (auto e = validate_code("student", opt.student); !e.empty()) return Error{e};
  if (opt.station.empty()) return Error{"no station given: pass --station-id CODE"};
  if (auto e = validate_code("station", opt.station); !e.empty()) return Error{e};
  std::error_code ec;
  fs::path dir = path, log;
  if (fs::is_regular_file(path, ec)) {
    log = path;
    dir = fs::path(path).parent_path();
    if (dir.empty()) dir = ".";
  } else if (fs::is_directory(path, ec)) {
    log = dir / "session.dlog";
  } else {
    return Error{path + ": no such session folder or log"};
  }
  if (!fs::is_regular_file(log, ec)) return Error{log.string() + ": no session log (session.dlog) here"};
  const fs::path rep = opt.report_dir.empty() ? dir : fs::path(opt.report_dir);
  const fs::path sj = rep / "score.json";
  if (!fs::is_regular_file(sj, ec))
    return Error{sj.string() + ": missing; score the session first (`dentar score " + dir.string() + "`)"};
  SessionRecord r;
  r.score_json = read_text(sj);
  json s;
  try {
    s = json::parse(r.score_json);
  } catch (const json::exception& e) {
    return Error{sj.string() + ": not valid JSON: " + e.what()};
  }
  if (!s.is_object() || str_of(s, "format") != "dentar-score")
    return Error{sj.string() + ": format is not \"dentar-score\" (written by `dentar score`)"};
  if (const fs::path html = rep / "score.html"; fs::is_regular_file(html, ec)) r.score_html = read_text(html);
  Sha h;
  if (auto st = hash_into(h, log.string(), &r.log_bytes); !st) return Error{st.error()};
  r.log_sha256 = h.hex();
  r.key = r.log_sha256;
  r.log_path = fs::absolute(log, ec).lexically_normal().string();
  r.report_dir = fs::absolute(rep, ec).lexically_normal().string();
  r.student = opt.student;
  r.station = opt.station;
  const json ex = s.contains("exercise") ? s["exercise"] : json::object();
  r.exercise = str_of(ex, "name");
  r.exercise_title = str_of(ex, "title");
  if (r.exercise.empty()) return Error{sj.string() + ": exercise.name missing"};
  if (auto e = validate_code("exercise", r.exercise); !e.empty()) return Error{sj.string() + ": " + e};
  if (s.contains("log_warning") && s["log_warning"].is_string()) r.log_warning = s["log_warning"].get<std::string>();
  const json out = s.contains("outcome") ? s["outcome"] : json::object();
  const json pr = s.contains("process") ? s["process"] : json::object();
  r.points = num(out, "points");
  r.max_points = num(out, "max_points");
  r.coverage_pct = num(out, "target_coverage_pct");
  r.overprep_mm3 = num(out, "overprep_mm3");
  r.forbidden_mm3 = num(out, "forbidden_mm3");
  r.removed_mm3 = num(out, "removed_total_mm3");
  r.pulp_exposed = out.is_object() && out.contains("pulp_exposed") && out["pulp_exposed"].is_boolean() && out["pulp_exposed"].get<bool>();
  r.perforation = out.is_object() && out.contains("perforation") && out["perforation"].is_boolean() && out["perforation"].get<bool>();
  r.duration_s = num(pr, "duration_s");
  r.drilling_s = num(pr, "drilling_s");
  r.path_mm = num(pr, "path_mm");
  r.excessive_force_s = num(pr, "excessive_force_s");
  flatten(out, "outcome", r.metrics);
  flatten(pr, "process", r.metrics);
  if (s.contains("steps") && s["steps"].is_array())
    for (const auto& st : s["steps"]) {
      if (!st.is_object()) continue;
      StepScore x;
      x.name = str_of(st, "name");
      x.start_s = num(st, "start_s");
      x.end_s = num(st, "end_s");
      x.drilling_s = num(st, "drilling_s");
      x.path_mm = num(st, "path_mm");
      x.removed_mm3 = num(st, "removed_mm3");
      x.force_N = vec3(st.contains("force_mean_N") ? st["force_mean_N"] : json());
      x.force_sd_N = vec3(st.contains("force_sd_N") ? st["force_sd_N"] : json());
      x.has_expert = st.contains("expert_force_mean_N") && st["expert_force_mean_N"].is_array();
      x.expert_force_N = vec3(x.has_expert ? st["expert_force_mean_N"] : json());
      x.expert_sd_N = vec3(st.contains("expert_force_sd_N") ? st["expert_force_sd_N"] : json());
      r.steps.push_back(x);
    }
  // feedback[].step: the step's index (-1 or absent: the whole session).
  if (s.contains("feedback") && s["feedback"].is_array())
    for (const auto& f : s["feedback"]) {
      if (!f.is_object()) continue;
      std::string step;
      if (f.contains("step") && f["step"].is_number_integer()) {
        const auto i = f["step"].get<long long>();
        if (i >= 0 && static_cast<std::size_t>(i) < r.steps.size()) step = r.steps[static_cast<std::size_t>(i)].name;
      } else if (f.contains("step") && f["step"].is_string()) {
        step = f["step"].get<std::string>();
      }
      r.feedback.push_back({step, str_of(f, "kind"), str_of(f, "text")});
    }
  // A session trained in a mode (issue 27): run.json of `dentar lesson run` beside the log
  // (mode, following error, the guidance) as metrics "training.*" for the instructor's page.
  if (const fs::path rj = dir / "run.json"; fs::is_regular_file(rj, ec)) {
    json run;
    try {
      run = json::parse(read_text(rj));
    } catch (const json::exception& e) {
      return Error{rj.string() + ": not valid JSON: " + e.what()};
    }
    if (!run.is_object() || !run.contains("mode") || !run["mode"].is_number_integer() || run["mode"].get<int>() < 1 ||
        run["mode"].get<int>() > 5)
      return Error{rj.string() + ": field mode must be a training mode 1..5 (run.json of `dentar lesson run`)"};
    for (const char* k : {"mode", "follow_error_mm", "expert_waited_s", "guidance"})
      if (run.contains(k)) flatten(run[k], std::string("training.") + k, r.metrics);
  }
  // Whose bur made the scored cut (score.json cut_by, issue 27): in modes 1-4 the expert's, so the
  // score is marked training.expert_cut and is never shown or averaged as the student's. A trained
  // session without run.json (a live one) takes its mode from score.json's training_mode.
  {
    bool has_mode = false;
    for (const auto& m : r.metrics) has_mode = has_mode || m.name == "training.mode";
    if (!has_mode && s.contains("training_mode") && s["training_mode"].is_number_integer()) {
      const int m = s["training_mode"].get<int>();
      if (m < 1 || m > 5) return Error{sj.string() + ": field training_mode = " + std::to_string(m) + " must be 1..5"};
      r.metrics.push_back({"training.mode", static_cast<double>(m), ""});
    }
    if (str_of(s, "cut_by") == "expert") r.metrics.push_back({"training.expert_cut", 1.0, "bool"});
  }
  // A live recording: its start time, and a hash over its description files.
  const fs::path rec = dir / "recording.json";
  if (fs::is_regular_file(rec, ec)) {
    try {
      const json rj = json::parse(read_text(rec));
      if (rj.is_object() && rj.contains("started") && rj["started"].is_string()) r.started_utc = rj["started"];
    } catch (const json::exception&) {
    }
    Sha rh;
    for (const char* f : {"recording.json", "station.json", "frames.csv"})
      if (fs::is_regular_file(dir / f, ec))
        if (auto st = hash_into(rh, (dir / f).string(), nullptr); !st) return Error{st.error()};
    r.recording_sha256 = rh.hex();
    r.recording_path = fs::absolute(dir, ec).lexically_normal().string();
  }
  if (r.started_utc.empty()) {
    // A bare log has no start time: it was last written when the session
    // ended, so the start is that time less the session's own duration
    // (score.json process.duration_s), not the time of the import.
    const auto ft = fs::last_write_time(log, ec);
    const auto dur = std::chrono::duration_cast<std::chrono::file_clock::duration>(
        std::chrono::duration<double>(std::max(0.0, r.duration_s)));
    const auto sys = std::chrono::time_point_cast<std::chrono::seconds>(
        std::chrono::file_clock::to_sys(ft - dur));
    const std::time_t t = std::chrono::system_clock::to_time_t(sys);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
    r.started_utc = b;
  }
  return r;
}

}  // namespace dentar::store
