// dentar score: scores a finished session (outcome, process, steps, feedback)
// and writes score.html (self-contained, SVG plots) and score.json beside it.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <memory>

#include "commands.h"
#include "dentar/training/report.h"
#include "dentar/session/finish.h"
#include "dentar/session/frames_csv.h"

namespace dentar::tools {
namespace {

struct ScoreCli {
  training::ScoreOptions opt;
  bool quiet = false;
};

// Mirror use and the recorded exercise come from the folder the session is
// in: a `dentar live --record` folder (station.json, frames.csv,
// recording.json) or a `dentar offline` run folder (frames.csv, and its
// summary.json naming the session log and station it used).
void fill_from_folder(training::ScoreOptions& o) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(o.session)) return;
  const fs::path d = o.session;
  std::string station = fs::exists(d / "station.json") ? (d / "station.json").string() : "";
  if (!fs::exists(d / "session.dlog") && fs::exists(d / "summary.json")) {
    std::ifstream f(d / "summary.json");
    auto j = nlohmann::json::parse(f, nullptr, false);
    if (j.is_object() && j.contains("inputs") && j["inputs"].is_object()) {
      const auto& in = j["inputs"];
      if (in.contains("session") && in["session"].is_string()) {
        if (o.out_dir.empty()) o.out_dir = d.string();
        if (o.frames_csv.empty() && fs::exists(d / "frames.csv")) o.frames_csv = (d / "frames.csv").string();
        o.session = in["session"].get<std::string>();
      }
      if (station.empty() && in.contains("station") && in["station"].is_string()) station = in["station"].get<std::string>();
    }
  }
  if (o.exercise.empty()) o.exercise = session::recorded_exercise(d.string());
  if (!station.empty() && !o.sight) {
    auto g = session::sight_from_station(station);
    if (!g) {
      std::cerr << "dentar score: warning: " << g.error() << " (mirror use not measured)\n";
      return;
    }
    o.sight = *g;
    o.sight_source = station;
  }
}

int run_score(const ScoreCli& c) {
  training::ScoreOptions opt = c.opt;
  opt.read_frames = session::read_view_frames;  // frames.csv's one reader
  fill_from_folder(opt);
  auto r = training::score_session(opt);
  if (!r) {
    print_error("score", r.error());
    // Bad input (missing file, damaged header, wrong exercise) is exit 2.
    return 2;
  }
  if (!r->log_warning.empty()) std::cerr << "dentar score: warning: " << r->log_warning << "\n";
  if (!c.quiet) std::cout << r->summary_text();
  return 0;
}

}  // namespace

void add_score(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<ScoreCli>();
  CLI::App* s = app.add_subcommand(
      "score",
      "Score a finished session: replay it on the starting tooth, outcome scores against the\n"
      "exercise, process metrics, steps found automatically, feedback against the experts;\n"
      "writes score.html and score.json.\n"
      "Synopsis: dentar score SESSION_DIR|SESSION.dlog [--exercise NAME|FILE] [--out DIR]\n"
      "                      [--reference FILE] [--model FILE] [--compare]");
  s->add_option("session", c->opt.session, "Session folder (holding session.dlog) or a .dlog file")->required();
  s->add_option("--exercise", c->opt.exercise,
                "Exercise: built-in name (molar_access_opening, molar_class1_cavity, incisor_partial_crown)\n"
                "or a JSON file; default: by the session's tooth");
  s->add_option("--out", c->opt.out_dir, "Output folder (default: the session's folder)");
  s->add_option("--reference", c->opt.reference,
                "Expert reference JSON (dentar assess --make-reference); default: generated expert sessions");
  s->add_option("--model", c->opt.model, "Skill model JSON (dentar assess --train ... --save) to classify the session");
  s->add_option("--reference-trials", c->opt.reference_trials, "Generated expert sessions for the default reference")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  s->add_flag("--compare", c->opt.compare,
              "Score a generated whole expert session and a novice session of the same exercise beside it\n"
              "(generated once, then cached with the expert reference)");
  s->add_flag("--quiet", c->quiet, "Print nothing but errors");
  s->footer("Example:\n  dentar demo --simulated --out out/demo && dentar score out/demo");
  s->callback([c, &exit_code] { exit_code = run_score(*c); });
}

}  // namespace dentar::tools
