#include "dentar/training/report.h"

#include <algorithm>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dentar/haptics/replay.h"
#include "dentar/training/cohort.h"

namespace dentar::training {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string num(double v, int prec = 2) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(prec);
  os << v;
  return os.str();
}

// Through a temporary file and a rename: a failed write never leaves half a file.
Status write_file_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());  // unique: runs may share a cache
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!(f << text) || !f.flush()) return Error{path + ": cannot write"};
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Error{path + ": cannot write: " + ec.message()};
  return {};
}

// Top (occlusal) view for molars, labial view for incisors: cells coloured by
// what happened along the line of sight.
std::string target_map_svg(const Exercise& ex, const RegionMasks& m, const volume::VoxelVolume& start,
                           const volume::VoxelVolume& cut, bool labial_view) {
  const auto d = start.dims();
  // View axis w; image axes (u right, v up).
  const int ua = 0, va = labial_view ? 2 : 1, wa = labial_view ? 1 : 2;
  const int nu = d[ua], nv = d[va], nw = d[wa];
  const int cell = std::max(1, std::max(nu, nv) / 110);
  const int cu = (nu + cell - 1) / cell, cv = (nv + cell - 1) / cell;
  std::vector<int> colour(static_cast<std::size_t>(cu * cv), 0);
  struct Acc { int solid = 0, target = 0, cut_target = 0, over = 0, forb = 0; };
  std::vector<Acc> acc(static_cast<std::size_t>(cu * cv));
  for (int iv = 0; iv < nv; ++iv)
    for (int iu = 0; iu < nu; ++iu) {
      Acc& a = acc[static_cast<std::size_t>((iv / cell) * cu + iu / cell)];
      for (int iw = 0; iw < nw; ++iw) {
        int ijk[3];
        ijk[ua] = iu;
        ijk[va] = iv;
        ijk[wa] = iw;
        const std::uint8_t d0 = start.density(ijk[0], ijk[1], ijk[2]);
        if (d0 <= volume::kIsoDensity) continue;
        const std::uint32_t b = m.bits[m.index(ijk[0], ijk[1], ijk[2])];
        const bool removed = cut.density(ijk[0], ijk[1], ijk[2]) <= volume::kIsoDensity;
        ++a.solid;
        if (b & m.target_bits) {
          ++a.target;
          if (removed) ++a.cut_target;
        } else if (removed) {
          ++a.over;
        }
        if ((b & m.forbidden_bits) && removed) ++a.forb;
      }
    }
  static const char* pal[] = {"none", "#d9d9d9", "#f2e394", "#9bd17f", "#3c9a3c", "#f4a340", "#d7301f"};
  for (std::size_t i = 0; i < acc.size(); ++i) {
    const Acc& a = acc[i];
    int c = 0;
    if (a.forb > 0) c = 6;
    else if (a.over > 0) c = 5;
    else if (a.target > 0) c = a.cut_target == 0 ? 2 : (a.cut_target * 2 < a.target ? 3 : 4);
    else if (a.solid > 0) c = 1;
    colour[i] = c;
  }
  const int px = 4, W = cu * px, H = cv * px;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W + 190 << "' height='" << std::max(H, 150)
    << "' font-family='sans-serif' font-size='11'><rect width='100%' height='100%' fill='white'/>";
  for (int y = 0; y < cv; ++y)
    for (int x = 0; x < cu;) {
      const int c = colour[static_cast<std::size_t>(y * cu + x)];
      int e = x;
      while (e < cu && colour[static_cast<std::size_t>(y * cu + e)] == c) ++e;
      if (c) s << "<rect x='" << x * px << "' y='" << (cv - 1 - y) * px << "' width='" << (e - x) * px << "' height='" << px
               << "' fill='" << pal[c] << "'/>";
      x = e;
    }
  const char* names[] = {"", "tooth, untouched", "target, not cut", "target, partly cut", "target, cut",
                         "cut outside the target", "cut into a forbidden region"};
  for (int c = 1; c <= 6; ++c)
    s << "<rect x='" << W + 10 << "' y='" << 10 + (c - 1) * 18 << "' width='12' height='12' fill='" << pal[c]
      << "'/><text x='" << W + 28 << "' y='" << 20 + (c - 1) * 18 << "'>" << names[c] << "</text>";
  s << "<text x='" << W + 10 << "' y='" << 10 + 6 * 18 + 10 << "'>" << (labial_view ? "labial view" : "occlusal view")
    << ", mesial left</text></svg>";
  (void)ex;
  return s.str();
}

std::string force_plot_svg(const SessionTrack& t, const std::vector<int>& steps, std::size_t n_steps) {
  const int W = 900, H = 260, L = 50, B = 30;
  if (t.size() < 2) return "<p>(no samples)</p>";
  double fmax = 0.5;
  for (const auto& f : t.force_N) fmax = std::max(fmax, f.cwiseAbs().maxCoeff());
  const double t0 = t.t_s.front(), t1 = t.t_s.back();
  auto X = [&](double tt) { return L + (W - L - 10) * (tt - t0) / std::max(1e-9, t1 - t0); };
  auto Y = [&](double f) { return 10 + (H - B - 10) * (0.5 - 0.5 * f / fmax); };
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H << "' font-family='sans-serif' font-size='11'><rect width='100%' height='100%' fill='white'/>";
  // Step bands.
  for (std::size_t i = 0; i < steps.size();) {
    std::size_t j = i;
    while (j < steps.size() && steps[j] == steps[i]) ++j;
    const double xa = X(t.t_s[i]), xb = X(t.t_s[j - 1]);
    s << "<rect x='" << xa << "' y='10' width='" << std::max(0.5, xb - xa) << "' height='" << H - B - 10 << "' fill='"
      << (steps[i] % 2 ? "#eef3fb" : "#f8f8f8") << "'/>";
    if (xb - xa > 14) s << "<text x='" << (xa + xb) / 2 - 4 << "' y='22' fill='#555'>" << steps[i] + 1 << "</text>";
    i = j;
  }
  (void)n_steps;
  s << "<line x1='" << L << "' y1='" << Y(0) << "' x2='" << W - 10 << "' y2='" << Y(0) << "' stroke='#999'/>";
  const char* col[3] = {"#1f77b4", "#2ca02c", "#d62728"};
  const std::size_t stride = std::max<std::size_t>(1, t.size() / 1500);
  for (int a = 0; a < 3; ++a) {
    s << "<polyline fill='none' stroke='" << col[a] << "' stroke-width='1' points='";
    for (std::size_t i = 0; i < t.size(); i += stride) s << num(X(t.t_s[i]), 1) << "," << num(Y(t.force_N[i](a)), 1) << " ";
    s << "'/>";
  }
  s << "<text x='5' y='" << Y(fmax) + 4 << "'>" << num(fmax, 1) << " N</text><text x='5' y='" << Y(-fmax) << "'>-"
    << num(fmax, 1) << " N</text><text x='" << L << "' y='" << H - 8 << "'>" << num(t0, 1) << " s</text><text x='"
    << W - 60 << "' y='" << H - 8 << "'>" << num(t1, 1) << " s</text>";
  const char* lab[3] = {"Fx mesio-distal", "Fy bucco-lingual", "Fz long axis"};
  for (int a = 0; a < 3; ++a)
    s << "<text x='" << 200 + a * 160 << "' y='" << H - 8 << "' fill='" << col[a] << "'>" << lab[a] << "</text>";
  s << "</svg>";
  return s.str();
}

// Per step: the student's mean force on each axis (dot) against the expert band (mean +- SD).
std::string step_band_svg(const ProcessMetrics& p, const ExpertReference& r) {
  const std::size_t S = p.steps.size();
  const int rowh = 22, W = 900, L = 260;
  const int H = static_cast<int>(S) * rowh + 40;
  double fmax = 0.5;
  for (std::size_t k = 0; k < S; ++k) {
    fmax = std::max(fmax, p.steps[k].force.mean.cwiseAbs().maxCoeff());
    if (k < r.steps.size()) fmax = std::max(fmax, (r.steps[k].force_mean.cwiseAbs() + r.steps[k].force_sd).maxCoeff());
  }
  const int pw = (W - L - 20) / 3;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H << "' font-family='sans-serif' font-size='11'><rect width='100%' height='100%' fill='white'/>";
  const char* lab[3] = {"Fx mesio-distal (N)", "Fy bucco-lingual (N)", "Fz long axis (N)"};
  for (int a = 0; a < 3; ++a) {
    const int x0 = L + a * pw;
    auto X = [&](double f) { return x0 + 5 + (pw - 10) * (0.5 + 0.5 * f / fmax); };
    s << "<text x='" << x0 + 5 << "' y='12'>" << lab[a] << "</text><line x1='" << X(0) << "' y1='18' x2='" << X(0)
      << "' y2='" << H - 20 << "' stroke='#bbb'/>";
    s << "<text x='" << x0 << "' y='" << H - 6 << "'>-" << num(fmax, 1) << "</text><text x='" << x0 + pw - 25 << "' y='"
      << H - 6 << "'>" << num(fmax, 1) << "</text>";
    for (std::size_t k = 0; k < S; ++k) {
      const double y = 24 + static_cast<double>(k) * rowh;
      if (k < r.steps.size() && r.steps[k].sessions > 0) {
        const double m = r.steps[k].force_mean(a), sd = r.steps[k].force_sd(a);
        s << "<rect x='" << X(m - sd) << "' y='" << y << "' width='" << std::max(1.0, X(m + sd) - X(m - sd))
          << "' height='14' fill='#c7dcef'/><line x1='" << X(m) << "' y1='" << y << "' x2='" << X(m) << "' y2='" << y + 14
          << "' stroke='#3b6ea5'/>";
      }
      if (p.steps[k].force.n > 0)
        s << "<circle cx='" << X(p.steps[k].force.mean(a)) << "' cy='" << y + 7 << "' r='4' fill='#d62728'/>";
    }
  }
  for (std::size_t k = 0; k < S; ++k)
    s << "<text x='4' y='" << 35 + static_cast<double>(k) * rowh << "'>" << k + 1 << ". " << esc(p.steps[k].name.substr(0, 38)) << "</text>";
  s << "</svg>";
  return s.str();
}

// Key of a generated reference: the exercise's steps, regions and tooth, the
// number of expert sessions and the cohort generator's version, so an edited
// exercise or a changed generator never reuses an old reference.
std::string reference_key(const Exercise& ex, int trials) {
  std::ostringstream k;
  k.precision(9);
  k << ex.name << '|' << ex.tooth_json << '|' << ex.bur.radius_m << '|' << ex.bur.length_m << '|' << trials << '|'
    << kCohortGeneratorVersion;
  for (const auto& st : ex.steps) {
    k << '|' << st.name << ',' << st.region << ',' << st.approach.transpose();
    if (st.focus_m) k << ',' << st.focus_m->transpose();
  }
  for (const auto& r : ex.regions) {
    k << '|' << r.name << ',' << static_cast<int>(r.role);
    for (const auto& p : r.all)
      k << ',' << static_cast<int>(p.kind) << ' ' << p.a_m.transpose() << ' ' << p.b_m.transpose() << ' ' << p.radius_m << ' '
        << p.depth_m << ' ' << static_cast<int>(p.material) << ' ' << p.negate;
  }
  // FNV-1a, 64 bit: a file name, not a security measure.
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : k.str()) h = (h ^ c) * 1099511628211ull;
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return ex.name + "_" + buf;
}

// Cache of generated references shared by every run on this machine:
// $DENTAR_CACHE_DIR, else $XDG_CACHE_HOME/dentar, else ~/.cache/dentar ("" = none).
std::string reference_cache_dir() {
  if (const char* d = std::getenv("DENTAR_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::string(d) + "/dentar";
  if (const char* d = std::getenv("HOME"); d && *d) return std::string(d) + "/.cache/dentar";
  return {};
}

// A private folder for work that is not kept (score without --out): unique per
// process, so concurrent runs never share one, and removed on every return.
struct Scratch {
  std::string path;
  explicit Scratch(bool make) {
    if (!make) return;
    std::string t = (fs::temp_directory_path() / "dentar_score_XXXXXX").string();
    if (::mkdtemp(t.data())) path = t;
  }
  ~Scratch() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
};

Result<ExpertReference> generated_reference(const Exercise& ex, const ScoreOptions& o, const std::string& out_dir) {
  const std::string cdir = reference_cache_dir();
  const std::string cache = cdir.empty() ? std::string() : cdir + "/expert_reference_" + reference_key(ex, o.reference_trials) + ".json";
  if (!cache.empty() && fs::exists(cache)) {
    std::ifstream f(cache);
    std::stringstream ss;
    ss << f.rdbuf();
    auto r = reference_from_json(ss.str(), cache);
    if (r && r->exercise == ex.name && r->steps.size() == ex.steps.size()) {
      std::ofstream(out_dir + "/expert_reference.json") << reference_to_json(*r) << "\n";  // the reference this report used
      return r;
    }
  }
  CohortOptions co;
  co.experts = o.reference_trials;  // one trial each of N expert subjects (subject-level spread)
  co.novices = 0;
  co.trials = 1;
  co.voxel_mm = 0.15;
  const std::string dir = out_dir + "/expert_cohort";
  auto trials = generate_cohort(ex, co, dir);
  if (!trials) return Error{"expert reference: " + trials.error()};
  std::vector<ProcessMetrics> pm;
  for (const auto& t : *trials) {
    auto log = haptics::read_session_log(t.session_path);
    if (!log) return Error{log.error()};
    auto tr = decode_session(*log, t.session_path);
    if (!tr) return Error{tr.error()};
    pm.push_back(process_metrics(*tr, ex, segment_steps(*tr, ex, nullptr, nullptr)));
  }
  ExpertReference r = build_reference(ex.name, pm);
  std::ofstream(out_dir + "/expert_reference.json") << reference_to_json(r) << "\n";
  if (!cache.empty()) {
    std::error_code ec;
    fs::create_directories(cdir, ec);
    // A cache that cannot be written only costs time next run.
    if (!ec) (void)write_file_atomic(cache, reference_to_json(r) + "\n");
  }
  fs::remove_all(dir);
  return r;
}

}  // namespace

Result<std::vector<ComparisonRow>> generated_comparison(const Exercise& ex, const std::string& work_dir) {
  const std::string cdir = reference_cache_dir();
  // The scores depend on the exercise's costs and completeness rules too
  // (bump kScoringVersion when the scoring itself changes).
  // 2: over-reduction (issue 25, session 11); 3: continuous access points and the wall taper
  // (session 14, which changed the scores without changing the key), graded pulp exposure (session 15).
  constexpr int kScoringVersion = 3;
  std::ostringstream sk;
  sk << reference_key(ex, 2) << '_' << kScoringVersion << '_' << ex.pulp_exposure_points() << '_' << ex.perforation_points()
     << '_' << ex.complete_coverage_pct << '_' << ex.complete_orifice_sight << '_' << ex.over_reduction_rate << '_' << ex.tolerance_mm;
  // Session 12's options, only when set (the shipped exercises keep their cached scores).
  if (ex.overprep_exercise_price) sk << "_exercise_price";
  if (ex.access_zone_rate > 0) sk << "_access_zone_" << ex.access_zone_rate << '_' << ex.access_zone_free_mm;
  if (ex.wall_overextension_points_per_mm > 0)
    sk << "_wall_overext_" << ex.wall_overextension_points_per_mm << '_' << ex.wall_overextension_free_mm << '_'
       << ex.wall_overextension_percentile;
  if (ex.pulp_exposure_full_mm > 0) sk << "_pulp_" << ex.pulp_exposure_full_mm << '_' << ex.pulp_exposure_min_fraction;
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a of the whole key: a file name
  for (unsigned char c : sk.str()) h = (h ^ c) * 1099511628211ull;
  char hx[20];
  std::snprintf(hx, sizeof hx, "%016llx", static_cast<unsigned long long>(h));
  const std::string cache = cdir.empty() ? std::string() : cdir + "/comparison_" + ex.name + "_" + hx + ".json";
  auto from_json = [](const json& j) {
    std::vector<ComparisonRow> v;
    for (const auto& r : j.at("rows"))
      v.push_back({r.at("label").get<std::string>(), r.at("points").get<double>(), r.at("max_points").get<double>(),
                   r.at("coverage_pct").get<double>(), r.at("duration_s").get<double>(), r.at("drilling_s").get<double>(),
                   r.at("complete").get<bool>(), r.at("completion").get<std::string>()});
    return v;
  };
  if (!cache.empty() && fs::exists(cache)) {
    std::ifstream f(cache);
    const json j = json::parse(f, nullptr, false);
    if (j.is_object() && j.contains("rows")) {
      try {
        return from_json(j);
      } catch (const json::exception&) {
        // a damaged cache is regenerated
      }
    }
  }
  CohortOptions co;
  co.experts = 1;
  co.novices = 1;
  co.trials = 1;
  co.separation = 1.0;
  co.voxel_mm = 0.15;
  co.seed = 25;
  const std::string dir = work_dir + "/comparison_cohort";
  auto trials = generate_cohort(ex, co, dir);
  if (!trials) return Error{"comparison: " + trials.error()};
  std::vector<ComparisonRow> rows;
  for (const auto& t : *trials) {
    auto log = haptics::read_session_log(t.session_path);
    if (!log) return Error{log.error()};
    auto setup = haptics::parse_session_header(log->header_json);
    if (!setup) return Error{t.session_path + ": " + setup.error()};
    auto start = make_start_tooth(setup->tooth_json, setup->volume_hash_start);
    if (!start) return Error{start.error()};
    volume::VoxelVolume cut = start->clone();
    if (auto rp = haptics::replay_session(*log, cut); !rp) return Error{t.session_path + ": replay: " + rp.error()};
    auto masks = build_masks(ex, *start);
    if (!masks) return Error{masks.error()};
    auto oc = score_outcome(ex, *masks, *start, cut);
    if (!oc) return Error{oc.error()};
    auto tr = decode_session(*log, t.session_path);
    if (!tr) return Error{tr.error()};
    const ProcessMetrics pm = process_metrics(*tr, ex, segment_steps(*tr, ex, &*masks, &*start));
    rows.push_back({t.label == "expert" ? "generated expert session" : "generated novice session", oc->points, oc->max_points,
                    oc->target_coverage_pct, pm.duration_s, pm.drilling_s, oc->complete, oc->completion});
  }
  fs::remove_all(dir);
  if (!cache.empty()) {
    json j = {{"format", "dentar-score-comparison"}, {"version", 1}, {"exercise", ex.name}, {"rows", json::array()}};
    for (const auto& r : rows)
      j["rows"].push_back({{"label", r.label}, {"points", r.points}, {"max_points", r.max_points},
                           {"coverage_pct", r.coverage_pct}, {"duration_s", r.duration_s}, {"drilling_s", r.drilling_s},
                           {"complete", r.complete}, {"completion", r.completion}});
    std::error_code ec;
    fs::create_directories(cdir, ec);
    if (!ec) (void)write_file_atomic(cache, j.dump(1) + "\n");
  }
  return rows;
}

std::string default_exercise_for(const std::string& tooth_json) {
  auto j = json::parse(tooth_json, nullptr, false);
  if (j.is_object() && j.value("kind", "") == "incisor") return "incisor_partial_crown";
  return "molar_access_opening";
}

std::string ScoreSummary::cut_label() const {
  return expert_cut() ? "expert's cut (mode " + std::to_string(training_mode) + ")" : "student's cut";
}

std::string ScoreSummary::summary_text() const {
  std::ostringstream s;
  s << "exercise: " << exercise_title << "\n";
  if (expert_cut()) s << "scored cut: the " << cut_label() << ", not the student's: the student's bur did not cut\n";
  s << "outcome: " << outcome.headline() << "\n  " << outcome.completion << "\n";
  for (const auto& p : outcome.penalties)
    if (p.points > 0) s << "  -" << num(p.points, 1) << " points, " << p.name << ": " << p.why << "\n";
  s << "  removed "
    << num(outcome.removed_total_mm3) << " mm3, target coverage " << num(outcome.target_coverage_pct, 1)
    << " %, over-preparation " << num(outcome.overprep_mm3) << " mm3, forbidden " << num(outcome.forbidden_mm3) << " mm3"
    << (outcome.pulp_exposed ? ", pulp exposed" : "") << (outcome.perforation ? ", PERFORATION" : "") << "\n";
  s << "process: " << num(process.duration_s, 1) << " s, drilling " << num(process.drilling_s, 1) << " s, path "
    << num(process.path_mm, 0) << " mm, excessive force " << num(process.excessive_force_s, 2) << " s\n";
  if (mirror.available) {
    s << "mirror use (site seen while drilling):";
    for (int c = 0; c < 4; ++c)
      s << " " << sightline_name(static_cast<Sightline>(c)) << " " << num(mirror.drilling_pct(static_cast<Sightline>(c)), 0) << " %";
    s << "\n";
  } else {
    s << "mirror use: unavailable (" << mirror.why << ")\n";
  }
  if (!comparison.empty()) {
    s << "beside finished sessions of the same exercise:\n";
    for (const auto& r : comparison)
      s << "  " << r.label << " (" << num(r.duration_s, 0) << " s, drilling " << num(r.drilling_s, 0) << " s): "
        << num(r.points, 1) << " / " << num(r.max_points, 0) << " points" << (r.complete ? ", " : ", INCOMPLETE: ")
        << (r.completion.rfind("incomplete: ", 0) == 0 ? r.completion.substr(12) : r.completion) << "\n";
  } else if (!comparison_warning.empty()) {
    s << "comparison: " << comparison_warning << "\n";
  }
  if (verdict) s << "assessment: " << verdict->label << " (margin " << num(verdict->margin, 3) << ")\n";
  s << "feedback: " << feedback.size() << " messages\n";
  for (const auto& f : feedback) s << "  - " << f.text << "\n";
  if (!report_html.empty()) s << "report: " << report_html << "\nsummary: " << summary_json << "\n";
  return s.str();
}

Result<ScoreSummary> score_session(const ScoreOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  ScoreSummary sum;
  std::string log_path = o.session;
  if (o.session.empty()) return Error{"score: no session given (a .dlog file or a folder holding session.dlog)"};
  if (fs::is_directory(o.session)) {
    log_path = (fs::path(o.session) / "session.dlog").string();
    if (!fs::exists(log_path))
      return Error{o.session + ": no session.dlog in this folder (record one with `dentar demo` or `dentar live --record DIR`)"};
    sum.station_found = fs::exists(fs::path(o.session) / "station.json");
  } else if (!fs::exists(o.session)) {
    return Error{o.session + ": no such file or folder"};
  }
  sum.session_path = log_path;
  const std::string out_dir = o.out_dir.empty() ? fs::path(log_path).parent_path().string() : o.out_dir;
  auto log = haptics::read_session_log(log_path);
  if (!log) return Error{log.error()};
  sum.log_warning = log->warning;
  if (log->records.empty()) return Error{log_path + ": the log holds no complete block of steps" +
                                         (log->warning.empty() ? std::string() : " (" + log->warning + ")")};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{log_path + ": " + setup.error()};
  if (setup->training) sum.training_mode = static_cast<int>(setup->training->params.mode);
  const std::string ex_name = o.exercise.empty() ? default_exercise_for(setup->tooth_json) : o.exercise;
  auto ex = load_named_exercise(ex_name);
  if (!ex) return Error{ex.error()};
  {
    auto a = json::parse(setup->tooth_json, nullptr, false), b = json::parse(ex->tooth_json, nullptr, false);
    const std::string ka = a.is_object() ? a.value("kind", "?") : "?", kb = b.value("kind", "?");
    if (ka != kb)
      return Error{log_path + ": the session was drilled on a " + ka + ", the exercise '" + ex->name + "' is for a " + kb +
                   " (choose another with --exercise)"};
  }
  sum.exercise_name = ex->name;
  sum.exercise_title = ex->title.empty() ? ex->name : ex->title;
  auto start = make_start_tooth(setup->tooth_json, setup->volume_hash_start);
  if (!start) return Error{log_path + ": cannot rebuild the session's tooth: " + start.error()};
  volume::VoxelVolume cut = start->clone();
  auto rep = haptics::replay_session(*log, cut);
  if (!rep) return Error{log_path + ": replay: " + rep.error()};
  auto masks = build_masks(*ex, *start);
  if (!masks) return Error{masks.error()};
  auto outcome = score_outcome(*ex, *masks, *start, cut);
  if (!outcome) return Error{outcome.error()};
  sum.outcome = *outcome;
  auto track = decode_session(*log, log_path);
  if (!track) return Error{track.error()};
  const std::vector<int> steps = segment_steps(*track, *ex, &*masks, &*start);
  sum.process = process_metrics(*track, *ex, steps);
  {
    // Mirror use needs camera frames and the station geometry; a session log alone has neither.
    std::string fcsv = o.frames_csv;
    if (fcsv.empty() && fs::is_directory(o.session) && fs::exists(fs::path(o.session) / "frames.csv"))
      fcsv = (fs::path(o.session) / "frames.csv").string();
    if (fcsv.empty()) {
      sum.mirror.why = "no camera frames with this session (a session log alone has no camera or mirror poses; "
                       "score a `dentar live --record` folder or a `dentar offline` run)";
    } else if (!o.sight) {
      sum.mirror.why = "no station geometry (station.json) to place the mirror and the tooth";
    } else if (!o.read_frames) {
      sum.mirror.why = "no frames.csv reader given to the scorer (session::read_view_frames)";
    } else {
      auto frames = o.read_frames(fcsv, setup->engine.rate_hz);
      if (!frames) {
        // A damaged frames.csv costs the mirror figures, not the score.
        sum.mirror.why = frames.error();
      } else {
        sum.mirror = mirror_use(*frames, *o.sight, *track, *ex, steps);
      }
    }
    sum.process.mirror_tracked = sum.mirror.available;
    if (sum.mirror.available)
      for (std::size_t k = 0; k < sum.process.steps.size() && k < sum.mirror.by_step.size(); ++k)
        sum.process.steps[k].views = sum.mirror.by_step[k];
  }
  if (o.write_files) {
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    if (ec) return Error{"score: cannot create '" + out_dir + "': " + ec.message()};
  }
  if (!o.reference.empty()) {
    std::ifstream f(o.reference);
    if (!f) return Error{o.reference + ": cannot open the expert reference"};
    std::stringstream ss;
    ss << f.rdbuf();
    auto r = reference_from_json(ss.str(), o.reference);
    if (!r) return Error{r.error()};
    if (r->steps.size() != ex->steps.size())
      return Error{o.reference + ": " + std::to_string(r->steps.size()) + " steps, the exercise '" + ex->name + "' has " +
                   std::to_string(ex->steps.size())};
    sum.reference = *r;
  }
  Scratch scratch(!o.write_files);
  if (!o.write_files && scratch.path.empty())
    return Error{"score: cannot create a scratch folder in " + fs::temp_directory_path().string() + " (set TMPDIR)"};
  const std::string work_dir = o.write_files ? out_dir : scratch.path;
  if (o.reference.empty()) {
    auto r = generated_reference(*ex, o, work_dir);
    if (!r) return Error{r.error()};
    sum.reference = *r;
  }
  sum.feedback = tutoring_feedback(sum.process, sum.reference, ex->excessive_force_N);
  // The feedback checks itself (docs/feedback.md); a broken rule is reported, never hidden.
  const std::vector<std::string> broken = feedback_violations(sum.process, sum.reference, ex->excessive_force_N, sum.feedback);
  if (o.compare) {
    auto cmp = generated_comparison(*ex, work_dir);
    if (!cmp) {
      sum.comparison_warning = cmp.error();
    } else {
      sum.comparison.push_back({"this session", sum.outcome.points, sum.outcome.max_points, sum.outcome.target_coverage_pct,
                                sum.process.duration_s, sum.process.drilling_s, sum.outcome.complete,
                                sum.outcome.completion});
      for (const auto& r : *cmp) sum.comparison.push_back(r);
    }
  }
  if (!o.model.empty()) {
    std::ifstream f(o.model);
    if (!f) return Error{o.model + ": cannot open the skill model"};
    std::stringstream ss;
    ss << f.rdbuf();
    auto m = model_from_json(ss.str(), o.model);
    if (!m) return Error{m.error()};
    auto v = classify(*m, track_features(*track));
    if (!v) return Error{o.model + ": " + v.error()};
    sum.verdict = *v;
  }
  // JSON summary.
  json j;
  j["format"] = "dentar-score";
  j["version"] = 1;
  j["session"] = log_path;
  j["exercise"] = {{"name", ex->name}, {"title", sum.exercise_title}};
  if (!sum.log_warning.empty()) j["log_warning"] = sum.log_warning;
  j["station_json_found"] = sum.station_found;
  // Whose bur made the scored cut: in training modes 1-4 the expert's (docs/formats.md).
  j["cut_by"] = sum.expert_cut() ? "expert" : "student";
  if (sum.training_mode != 0) j["training_mode"] = sum.training_mode;
  const OutcomeScores& oc = sum.outcome;
  json rem = json::object();
  for (int m = 1; m < volume::kNumMaterials; ++m)
    rem[std::string(volume::material_name(static_cast<volume::Material>(m)))] = oc.removed_mm3[static_cast<std::size_t>(m)];
  j["outcome"] = {{"points", oc.points}, {"max_points", oc.max_points}, {"removed_mm3", rem},
                  {"removed_total_mm3", oc.removed_total_mm3}, {"target_mm3", oc.target_mm3},
                  {"target_coverage_pct", oc.target_coverage_pct}, {"overprep_mm3", oc.overprep_mm3},
                  {"forbidden_mm3", oc.forbidden_mm3}, {"pulp_exposed", oc.pulp_exposed}, {"pulp_wall_opened", oc.pulp_wall_opened},
                  {"perforation", oc.perforation}, {"perforation_mm3", oc.perforation_mm3},
                  {"earned_points", oc.earned_points}, {"complete", oc.complete}, {"completion", oc.completion}};
  j["outcome"]["penalties"] = json::array();
  for (const auto& pe : oc.penalties)
    j["outcome"]["penalties"].push_back({{"name", pe.name}, {"points", pe.points}, {"why", pe.why}});
  j["outcome"]["regions"] = json::array();
  for (const auto& r : oc.regions)
    j["outcome"]["regions"].push_back({{"name", r.name}, {"coverage_pct", r.coverage_pct}, {"overprep_mm3", r.overprep_mm3},
                                       {"points", r.points}, {"max_points", r.max_points}, {"why", r.why}});
  j["outcome"]["criteria"] = json::array();
  for (const auto& c : oc.criteria)
    j["outcome"]["criteria"].push_back({{"name", c.name}, {"score", c.score}, {"max_score", c.max_score}, {"value", c.value}, {"unit", c.unit}, {"detail", c.detail}});
  const ProcessMetrics& p = sum.process;
  j["process"] = {{"duration_s", p.duration_s}, {"drilling_s", p.drilling_s}, {"path_mm", p.path_mm},
                  {"excessive_force_s", p.excessive_force_s}, {"excessive_force_N", p.excessive_force_N},
                  {"mirror_tracked", p.mirror_tracked}, {"watchdog_frames", p.watchdog_frames}};
  {
    const MirrorUse& mu = sum.mirror;
    json mj = {{"available", mu.available}};
    if (!mu.available) {
      mj["why"] = mu.why;
    } else {
      mj["frames"] = mu.frames;
      mj["frames_tracked"] = mu.frames_tracked;
      mj["frames_mirror_tracked"] = mu.frames_mirror_tracked;
      json all = json::object(), dr = json::object(), pct = json::object();
      for (int c = 0; c < 4; ++c) {
        const char* n = sightline_name(static_cast<Sightline>(c));
        all[n] = mu.all[static_cast<std::size_t>(c)];
        dr[n] = mu.drilling[static_cast<std::size_t>(c)];
        pct[n] = mu.drilling_pct(static_cast<Sightline>(c));
      }
      mj["frames_by_class"] = all;
      mj["drilling_frames_by_class"] = dr;
      mj["drilling_pct"] = pct;
      if (!o.sight_source.empty()) mj["station"] = o.sight_source;
    }
    j["process"]["mirror_use"] = mj;
  }
  j["process"]["force_by_material"] = json::object();
  for (int m = 1; m < volume::kNumMaterials; ++m) {
    const ForceStats& f = p.force_by_material[static_cast<std::size_t>(m)];
    if (f.n > 0)
      j["process"]["force_by_material"][std::string(volume::material_name(static_cast<volume::Material>(m)))] =
          {{"frames", f.n}, {"mean_N", f.mean_magnitude}, {"max_N", f.max_magnitude}};
  }
  j["steps"] = json::array();
  for (std::size_t k = 0; k < p.steps.size(); ++k) {
    const StepMetrics& s = p.steps[k];
    json sj = {{"name", s.name}, {"start_s", s.start_s}, {"end_s", s.end_s}, {"drilling_s", s.drilling_s},
               {"path_mm", s.path_mm}, {"removed_mm3", s.removed_mm3},
               {"force_mean_N", {s.force.mean.x(), s.force.mean.y(), s.force.mean.z()}},
               {"force_sd_N", {s.force.sd.x(), s.force.sd.y(), s.force.sd.z()}}};
    if (sum.mirror.available && k < sum.mirror.by_step.size()) {
      json mu = json::object();
      for (int c = 0; c < 4; ++c) mu[sightline_name(static_cast<Sightline>(c))] = sum.mirror.by_step[k][static_cast<std::size_t>(c)];
      sj["mirror_use_drilling_frames"] = mu;
    }
    if (k < sum.reference.steps.size()) {
      const auto& e = sum.reference.steps[k];
      sj["expert_force_mean_N"] = {e.force_mean.x(), e.force_mean.y(), e.force_mean.z()};
      sj["expert_force_sd_N"] = {e.force_sd.x(), e.force_sd.y(), e.force_sd.z()};
    }
    j["steps"].push_back(sj);
  }
  if (!broken.empty()) j["feedback_rule_violations"] = broken;
  j["feedback"] = json::array();
  for (const auto& f : sum.feedback)
    j["feedback"].push_back({{"step", f.step}, {"kind", f.kind}, {"rule", f.rule}, {"text", f.text}});
  if (!sum.comparison.empty()) {
    j["comparison"] = json::array();
    for (const auto& r : sum.comparison)
      j["comparison"].push_back({{"label", r.label}, {"points", r.points}, {"max_points", r.max_points},
                                 {"coverage_pct", r.coverage_pct}, {"duration_s", r.duration_s}, {"drilling_s", r.drilling_s},
                                 {"complete", r.complete}, {"completion", r.completion}});
  } else if (!sum.comparison_warning.empty()) {
    j["comparison_warning"] = sum.comparison_warning;
  }
  if (sum.verdict) j["assessment"] = {{"label", sum.verdict->label}, {"margin", sum.verdict->margin}, {"scores", sum.verdict->score}};
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  j["scoring_seconds"] = sum.seconds;
  if (!o.write_files) return sum;

  sum.summary_json = (fs::path(out_dir) / "score.json").string();
  if (Status st = write_file_atomic(sum.summary_json, j.dump(1) + "\n"); !st) return Error{st.error()};
  // HTML report.
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset='utf-8'><title>DentAR session report</title><style>"
       "body{font-family:sans-serif;max-width:960px;margin:20px auto;color:#222}table{border-collapse:collapse;margin:8px 0}"
       "td,th{border:1px solid #ccc;padding:3px 8px;text-align:left}th{background:#f0f0f0}.big{font-size:28px;font-weight:bold}"
       ".well_done{color:#2a7a2a}.ask{color:#1f5fa0}.caution{color:#b03020}</style></head><body>";
  h << "<h1>Session report</h1><p>" << esc(sum.exercise_title) << "<br>session: <code>" << esc(log_path) << "</code></p>";
  if (!sum.log_warning.empty()) h << "<p class='caution'>Log damaged: " << esc(sum.log_warning) << "</p>";
  if (sum.expert_cut())
    h << "<p class='caution' id='cut-by'>This is the " << esc(sum.cut_label())
      << ", not the student's: in training modes 1-4 the expert's bur cuts and the student's does not.</p>";
  h << "<p class='big'>" << num(oc.points, 1) << " / " << num(oc.max_points, 0) << " points"
    << (oc.complete ? "" : " <span class='caution'>INCOMPLETE</span>") << "</p><p" << (oc.complete ? "" : " class='caution'")
    << ">" << esc(oc.completion) << (oc.complete ? "" : " The points are what the unfinished preparation earned so far; "
                                                      "they do not rank it against finished ones.")
    << "</p>";
  if (!oc.penalties.empty()) {
    h << "<table><tr><th>cost</th><th>points</th><th>why</th></tr>";
    for (const auto& pe : oc.penalties)
      h << "<tr><td>" << esc(pe.name) << "</td><td>-" << num(pe.points, 1) << "</td><td>" << esc(pe.why) << "</td></tr>";
    h << "</table><p>Earned " << num(oc.earned_points, 1) << " points before these costs.</p>";
  }
  if (!sum.comparison.empty()) {
    h << "<h2>Beside finished sessions of the same exercise</h2><table><tr><th>session</th><th>time</th><th>drilling</th>"
         "<th>target removed</th><th>points</th><th>finished?</th></tr>";
    for (const auto& r : sum.comparison)
      h << "<tr><td>" << esc(r.label) << "</td><td>" << num(r.duration_s, 0) << " s</td><td>" << num(r.drilling_s, 0)
        << " s</td><td>" << num(r.coverage_pct, 0) << " %</td><td>" << num(r.points, 1) << " / " << num(r.max_points, 0)
        << "</td><td" << (r.complete ? ">" : " class='caution'>") << esc(r.completion) << "</td></tr>";
    h << "</table><p>The expert and novice sessions are generated (cohort generator, skill separation 0 and 1, 0.15 mm "
         "voxels) and scored the same way.</p>";
  }
  if (sum.verdict) h << "<p>Skill assessment: <b>" << esc(sum.verdict->label) << "</b> (score margin " << num(sum.verdict->margin, 3) << ")</p>";
  h << "<h2>Outcome</h2><table><tr><th>measure</th><th>value</th></tr>";
  for (int m = 1; m < volume::kNumMaterials; ++m)
    if (oc.removed_mm3[static_cast<std::size_t>(m)] > 0)
      h << "<tr><td>removed " << volume::material_name(static_cast<volume::Material>(m)) << "</td><td>"
        << num(oc.removed_mm3[static_cast<std::size_t>(m)]) << " mm&sup3;</td></tr>";
  h << "<tr><td>target coverage</td><td>" << num(oc.target_coverage_pct, 1) << " %</td></tr><tr><td>over-preparation</td><td>"
    << num(oc.overprep_mm3) << " mm&sup3;</td></tr><tr><td>forbidden regions</td><td>" << num(oc.forbidden_mm3)
    << " mm&sup3;</td></tr><tr><td>pulp exposure</td><td>" << (oc.pulp_exposed ? "yes" : "no")
    << "</td></tr><tr><td>perforation</td><td>" << (oc.perforation ? "yes (" + num(oc.perforation_mm3) + " mm&sup3;)" : "no")
    << "</td></tr></table>";
  if (!oc.criteria.empty()) {
    h << "<table><tr><th>criterion</th><th>score</th><th>why</th></tr>";
    for (const auto& c : oc.criteria)
      h << "<tr><td>" << esc(c.name) << "</td><td>" << num(c.score, 2) << " / " << num(c.max_score, 0) << "</td><td>"
        << esc(c.detail) << "</td></tr>";
    h << "</table>";
  }
  // Graded regions (their points): also beside a graded exercise's wall taper.
  if (oc.criteria.empty() ||
      std::any_of(oc.regions.begin(), oc.regions.end(), [](const RegionScore& r) { return r.max_points > 0; })) {
    h << "<table><tr><th>region</th><th>coverage</th><th>over-preparation nearby</th><th>points</th><th>why</th></tr>";
    for (const auto& r : oc.regions)
      h << "<tr><td>" << esc(r.name) << "</td><td>" << num(r.coverage_pct, 1) << " %</td><td>" << num(r.overprep_mm3)
        << " mm&sup3;</td><td>" << num(r.points, 1) << " / " << num(r.max_points, 0) << "</td><td>" << esc(r.why)
        << "</td></tr>";
    h << "</table>";
  }
  h << "<h3>Target map against the cut</h3>"
    << target_map_svg(*ex, *masks, *start, cut, json::parse(setup->tooth_json).value("kind", "") == "incisor");
  h << "<h2>Feedback</h2><ul>";
  for (const auto& f : sum.feedback) h << "<li class='" << f.kind << "'>" << esc(f.text) << "</li>";
  if (sum.feedback.empty()) h << "<li>No step could be compared with the experts.</li>";
  h << "</ul><h2>Force along the tooth's axes, by step</h2>"
    << force_plot_svg(*track, steps, ex->steps.size())
    << "<p>Force the bur presses on the tooth, tooth frame (x mesio-distal, y bucco-lingual, z long axis); shaded bands: "
       "steps found automatically.</p>"
    << "<h3>Student (red) against the expert band (mean &plusmn; SD), per step</h3>" << step_band_svg(p, sum.reference);
  const ExpertReference& r = sum.reference;
  h << "<h2>Process</h2><table><tr><th>measure</th><th>you</th><th>experts (mean &plusmn; SD)</th></tr>"
    << "<tr><td>time</td><td>" << num(p.duration_s, 1) << " s</td><td>" << num(r.duration_mean_s, 1) << " &plusmn; " << num(r.duration_sd_s, 1) << " s</td></tr>"
    << "<tr><td>drilling time</td><td>" << num(p.drilling_s, 1) << " s</td><td>" << num(r.drilling_mean_s, 1) << " &plusmn; " << num(r.drilling_sd_s, 1) << " s</td></tr>"
    << "<tr><td>path length</td><td>" << num(p.path_mm, 0) << " mm</td><td>" << num(r.path_mean_mm, 0) << " &plusmn; " << num(r.path_sd_mm, 0) << " mm</td></tr>"
    << "<tr><td>drilling with force &gt; " << num(p.excessive_force_N, 1) << " N</td><td>" << num(p.excessive_force_s, 2) << " s</td><td>"
    << num(r.excessive_mean_s, 2) << " &plusmn; " << num(r.excessive_sd_s, 2) << " s</td></tr>"
    << "<tr><td>mirror use</td><td colspan='2'>";
  if (!sum.mirror.available) {
    h << "unavailable: " << esc(sum.mirror.why);
  } else {
    h << "site seen while drilling: ";
    for (int c = 0; c < 4; ++c)
      h << (c ? ", " : "") << sightline_name(static_cast<Sightline>(c)) << " " << num(sum.mirror.drilling_pct(static_cast<Sightline>(c)), 0) << " %";
    h << " (" << sum.mirror.frames_tracked << " camera frames with the mannequin tracked, mirror tracked in "
      << sum.mirror.frames_mirror_tracked << ")";
  }
  h << "</td></tr></table>";
  h << "<table><tr><th>step</th><th>time (s)</th><th>drilling (s)</th><th>removed (mm&sup3;)</th><th>mean force (N)</th></tr>";
  for (std::size_t k = 0; k < p.steps.size(); ++k)
    h << "<tr><td>" << k + 1 << ". " << esc(p.steps[k].name) << "</td><td>" << num(p.steps[k].start_s, 1) << " - "
      << num(p.steps[k].end_s, 1) << "</td><td>" << num(p.steps[k].drilling_s, 1) << "</td><td>" << num(p.steps[k].removed_mm3)
      << "</td><td>" << num(p.steps[k].force.mean_magnitude) << "</td></tr>";
  h << "</table><p>Expert band: " << (o.reference.empty() ? "generated expert sessions (cohort generator, " + std::to_string(o.reference_trials) + " trials)" : esc(o.reference))
    << ". Scored in " << num(sum.seconds, 2) << " s.</p></body></html>\n";
  sum.report_html = (fs::path(out_dir) / "score.html").string();
  if (Status st = write_file_atomic(sum.report_html, h.str()); !st) return Error{st.error()};
  return sum;
}

}  // namespace dentar::training
