// How well training::segment_steps finds the procedure's steps (the score report's
// per-step figures, the feedback, the process metrics and the replay timeline use it).
// Not a Google Benchmark: one run, one table (docs/BENCHMARKS.md, "training/ — the
// steps' flicker").
//
// Labelled sessions: generated cohorts (the generator knows which step each moment
// belongs to), with personal style so the sessions carry the faults a real hand has
// (tilt and posture habits, tremor, pauses). Per exercise and per switch-cost setting:
// agreement with the generator's labels over the frames that cut, and the number of
// spans against the number of true steps (flicker shows as many more spans than steps).
//
// Unlabelled sessions (--sessions DIR...; a folder with session.dlog, e.g. `dentar live
// --record`): spans, returns to an earlier step, and the shortest span, per session.
//
//   build/training/training_segment_bench [--seeds 7] [--experts 4] [--novices 4] [--style 1]
//       [--exercise NAME]... [--costs 100/10000,4/40] [--keep DIR]
//       [--sessions DIR --sessions-exercise NAME]...
// --costs: next/jump switch costs to compare in the same run (the first is the default
// under test; 4/40 were the costs before session 14).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/haptics/session_log.h"
#include "dentar/training/cohort.h"
#include "dentar/training/exercise.h"
#include "dentar/training/session.h"

namespace {

using namespace dentar;
using namespace dentar::training;

struct Costs {
  double next = 0, jump = 0;
};

int count_spans(const std::vector<int>& s) {
  int n = s.empty() ? 0 : 1;
  for (std::size_t i = 1; i < s.size(); ++i) n += s[i] != s[i - 1];
  return n;
}

// Spans that go back to a step already left (A, B, A), and the shortest span (s).
void returns_and_shortest(const std::vector<int>& s, const std::vector<double>& t, int& returns,
                          double& shortest_s) {
  returns = 0;
  shortest_s = t.empty() ? 0 : t.back() - t.front();
  std::vector<int> seen;
  std::size_t b = 0;
  for (std::size_t i = 1; i <= s.size(); ++i) {
    if (i < s.size() && s[i] == s[b]) continue;
    const double len = (i < s.size() ? t[i] : t.back()) - t[b];
    if (b > 0 && i < s.size()) shortest_s = std::min(shortest_s, len);
    if (std::find(seen.begin(), seen.end(), s[b]) != seen.end()) ++returns;
    seen.push_back(s[b]);
    b = i;
  }
}

struct Prepared {
  SessionTrack track;
  volume::VoxelVolume start;
  RegionMasks masks;
};

Result<Prepared> prepare(const std::string& session_path, const Exercise& ex) {
  auto log = haptics::read_session_log(session_path);
  if (!log) return Error{log.error()};
  auto track = decode_session(*log, session_path);
  if (!track) return Error{track.error()};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{session_path + ": " + setup.error()};
  auto start = make_tooth(setup->tooth_json);
  if (!start) return Error{session_path + ": " + start.error()};
  auto masks = build_masks(ex, *start);
  if (!masks) return Error{session_path + ": " + masks.error()};
  return Prepared{std::move(*track), std::move(*start), std::move(*masks)};
}

int usage(const std::string& why) {
  std::fprintf(stderr,
               "training_segment_bench: %s\n"
               "usage: training_segment_bench [--seeds 7,8] [--experts N] [--novices N] [--style S] "
               "[--exercise NAME]... [--costs NEXT/JUMP,...] [--keep DIR] [--sessions DIR --sessions-exercise NAME]...\n",
               why.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::uint64_t> seeds = {7};
  int experts = 4, novices = 4;
  double style = 1.0;
  std::vector<std::string> exercises;
  std::vector<Costs> costs;
  std::string keep;
  std::vector<std::pair<std::string, std::string>> sessions;  // folder, exercise
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&]() -> std::optional<std::string> {
      if (i + 1 >= argc) return std::nullopt;
      return std::string(argv[++i]);
    };
    std::optional<std::string> v = val();
    if (!v) return usage(a + " needs a value");
    char* end = nullptr;
    if (a == "--seeds") {
      seeds.clear();
      std::stringstream ss(*v);
      for (std::string s; std::getline(ss, s, ',');) {
        const unsigned long long x = std::strtoull(s.c_str(), &end, 10);
        if (s.empty() || *end) return usage("--seeds: '" + s + "' is not a whole number");
        seeds.push_back(x);
      }
    } else if (a == "--experts" || a == "--novices") {
      const long x = std::strtol(v->c_str(), &end, 10);
      if (*end || x < 0 || x > 50) return usage(a + ": '" + *v + "' is not a count in [0, 50]");
      (a == "--experts" ? experts : novices) = static_cast<int>(x);
    } else if (a == "--style") {
      style = std::strtod(v->c_str(), &end);
      if (*end || style < 0 || style > 3) return usage("--style: '" + *v + "' is not in [0, 3]");
    } else if (a == "--exercise") {
      exercises.push_back(*v);
    } else if (a == "--costs") {
      std::stringstream ss(*v);
      for (std::string s; std::getline(ss, s, ',');) {
        Costs c;
        const auto slash = s.find('/');
        if (slash == std::string::npos) return usage("--costs: '" + s + "' is not NEXT/JUMP");
        c.next = std::strtod(s.substr(0, slash).c_str(), &end);
        if (*end) return usage("--costs: '" + s + "' is not NEXT/JUMP");
        c.jump = std::strtod(s.substr(slash + 1).c_str(), &end);
        if (*end || c.next < 0 || c.jump < 0) return usage("--costs: '" + s + "' is not NEXT/JUMP (>= 0)");
        costs.push_back(c);
      }
    } else if (a == "--keep") {
      keep = *v;
    } else if (a == "--sessions") {
      sessions.emplace_back(*v, "");
    } else if (a == "--sessions-exercise") {
      if (sessions.empty() || !sessions.back().second.empty())
        return usage("--sessions-exercise follows its --sessions DIR");
      sessions.back().second = *v;
    } else {
      return usage("unknown option " + a);
    }
  }
  if (costs.empty()) {
    const SegmentOptions d;
    costs = {{d.next_cost, d.jump_cost}, {4, 40}};
  }
  if (exercises.empty() && sessions.empty())
    exercises = {"molar_class1_cavity", "molar_access_opening", "incisor_partial_crown"};
  const std::string dir = keep.empty() ? (std::filesystem::temp_directory_path() /
                                          ("dentar_segment_bench_" + std::to_string(::getpid())))
                                             .string()
                                       : keep;

  if (!exercises.empty()) {
    std::printf("| exercise | seed | costs next/jump | sessions | agreement (cutting frames) | "
                "experts | novices | spans / true steps | returns |\n|---|---|---|---|---|---|---|---|---|\n");
  }
  int rc = 0;
  for (const std::string& name : exercises) {
    auto ex = load_named_exercise(name);
    if (!ex) return usage(ex.error());
    for (const std::uint64_t seed : seeds) {
      CohortOptions co;
      co.experts = experts;
      co.novices = novices;
      co.trials = 1;
      co.style = style;
      co.seed = seed;
      co.bur_samples = 500;
      const std::string d = dir + "/" + name + "_s" + std::to_string(seed);
      const bool reuse = std::filesystem::exists(d + "/trials.csv");
      auto trials = reuse ? read_cohort(d) : generate_cohort(*ex, co, d);
      if (!trials) {
        std::fprintf(stderr, "%s\n", trials.error().c_str());
        rc = 1;
        continue;
      }
      std::vector<Prepared> prepared;
      for (const auto& t : *trials) {
        auto p = prepare(t.session_path, *ex);
        if (!p) {
          std::fprintf(stderr, "%s\n", p.error().c_str());
          return 1;
        }
        prepared.push_back(std::move(*p));
      }
      for (const Costs& c : costs) {
        SegmentOptions o;
        o.next_cost = c.next;
        o.jump_cost = c.jump;
        double agree[2] = {0, 0}, n[2] = {0, 0};
        int spans = 0, truth_spans = 0, returns = 0;
        for (std::size_t q = 0; q < trials->size(); ++q) {
          const CohortTrial& tr = (*trials)[q];
          const Prepared& p = prepared[q];
          const std::vector<int> steps = segment_steps(p.track, *ex, &p.masks, &p.start, o);
          const int g = tr.label == "expert" ? 0 : 1;
          int last = -1;
          for (std::size_t f = 0; f < steps.size(); ++f) {
            const int t = tr.true_step_at(p.track.t_s[f]);
            if (t >= 0 && t != last) ++truth_spans, last = t;
            if (t < 0 || p.track.removed_total(f) <= 0) continue;
            agree[g] += steps[f] == t;
            n[g] += 1;
          }
          int r = 0;
          double shortest = 0;
          returns_and_shortest(steps, p.track.t_s, r, shortest);
          spans += count_spans(steps);
          returns += r;
        }
        auto frac = [](double a, double b) { return b > 0 ? a / b : 0.0; };
        std::printf("| %s | %llu | %g/%g | %zu | %.3f | %.3f | %.3f | %d / %d | %d |\n", name.c_str(),
                    static_cast<unsigned long long>(seed), c.next, c.jump, trials->size(),
                    frac(agree[0] + agree[1], n[0] + n[1]), frac(agree[0], n[0]), frac(agree[1], n[1]), spans,
                    truth_spans, returns);
        std::fflush(stdout);
      }
    }
  }

  if (!sessions.empty()) {
    std::printf("\n| session | exercise | costs next/jump | length s | exercise steps | spans | returns | "
                "shortest inner span s |\n|---|---|---|---|---|---|---|---|\n");
  }
  for (const auto& [folder, exname] : sessions) {
    if (exname.empty()) return usage("--sessions " + folder + " needs --sessions-exercise NAME");
    auto ex = load_named_exercise(exname);
    if (!ex) return usage(ex.error());
    const std::string path = folder + "/session.dlog";
    auto p = prepare(path, *ex);
    if (!p) {
      std::fprintf(stderr, "%s\n", p.error().c_str());
      rc = 1;
      continue;
    }
    for (const Costs& c : costs) {
      SegmentOptions o;
      o.next_cost = c.next;
      o.jump_cost = c.jump;
      const std::vector<int> steps = segment_steps(p->track, *ex, &p->masks, &p->start, o);
      int r = 0;
      double shortest = 0;
      returns_and_shortest(steps, p->track.t_s, r, shortest);
      std::printf("| %s | %s | %g/%g | %.0f | %zu | %d | %d | %.2f |\n", folder.c_str(), exname.c_str(), c.next,
                  c.jump, p->track.t_s.empty() ? 0.0 : p->track.t_s.back() - p->track.t_s.front(),
                  ex->steps.size(), count_spans(steps), r, shortest);
    }
  }
  if (keep.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  return rc;
}
