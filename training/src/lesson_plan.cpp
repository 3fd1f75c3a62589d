#include "dentar/training/lesson_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/replay_device.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/session.h"
#include "dentar/volume/bur.h"

namespace dentar::training {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string mm(double m) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f mm", m * 1e3);
  return b;
}
std::string pct(double f) {
  char b[32];
  std::snprintf(b, sizeof b, "%.0f %%", f * 100);
  return b;
}
const char* mode_label(int m) {
  switch (m) {
    case 1: return "mode 1 (visual replay)";
    case 2: return "mode 2 (passive guidance)";
    case 3: return "mode 3 (active following)";
    case 4: return "mode 4 (force reversal)";
    case 5: return "mode 5 (hints)";
    default: return "plain drilling";
  }
}

// The newest session with a following error in a mode that measures one (2, 3, 4).
const PastSession* last_following(const std::vector<PastSession>& h) {
  for (auto it = h.rbegin(); it != h.rend(); ++it)
    if (it->has_follow && it->mode >= 2 && it->mode <= 4) return &*it;
  return nullptr;
}

// A trained session without run.json (a live one): its following error, by replaying it
// with its mode (as haptics::replay_session does, the expert's recording read and checked)
// and reading the engine's snapshot after every step; the same statistic as run.json's
// (after the expert's first 0.5 s, mean and p95).
Status replay_follow_error(const haptics::SessionLog& log, const haptics::SessionSetup& setup,
                           const std::string& name, PastSession& s) {
  const haptics::TrainingSetup& t = *setup.training;
  auto vol = make_start_tooth(setup.tooth_json, setup.volume_hash_start);
  if (!vol) return Error{name + ": tooth: " + vol.error()};
  if (vol->content_hash() != setup.volume_hash_start)
    return Error{name + ": the rebuilt tooth does not match the log's volume_hash_start"};
  auto bur = volume::sample_bur(setup.bur, setup.bur_samples);
  if (!bur) return Error{name + ": bur: " + bur.error()};
  auto track = haptics::load_trained_expert(t);
  if (!track) return Error{name + ": " + track.error()};
  auto mode = haptics::TrainingMode::create(t.params, *track);
  if (!mode) return Error{name + ": training: " + mode.error()};
  haptics::ReplayDevice dev(log.records, setup.limits);
  haptics::EngineConfig cfg = setup.engine;
  cfg.training = &*mode;
  cfg.try_realtime = false;
  auto engine = haptics::Engine::create(cfg, dev, *vol, *bur, nullptr);
  if (!engine) return Error{name + ": " + engine.error()};
  std::vector<double> err;
  err.reserve(log.records.size());
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    (*engine)->run_steps(1);
    const haptics::HapticSnapshot snap = (*engine)->snapshot();
    if (snap.expert_time_s >= 0.5) err.push_back(snap.follow_error_m);
  }
  if (err.empty()) return {};  // shorter than 0.5 s of the expert: not measured
  s.has_follow = true;
  s.follow_from = "replay";
  double sum = 0;
  for (double e : err) sum += e;
  s.follow_mean_m = sum / static_cast<double>(err.size());
  std::sort(err.begin(), err.end());
  s.follow_p95_m = err[err.size() * 95 / 100];
  return {};
}

}  // namespace

std::string PlanOptions::validate() const {
  auto pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (!pos(on_path_m)) return "on_path_m must be > 0";
  if (!pos(close_m) || close_m < on_path_m) return "close_m must be >= on_path_m";
  if (!pos(strayed_m) || strayed_m < close_m) return "strayed_m must be >= close_m";
  if (!(novice_score >= 0 && novice_score < skilled_score && skilled_score <= 1))
    return "novice_score and skilled_score must satisfy 0 <= novice_score < skilled_score <= 1";
  if (!(fade > 0 && fade < 1)) return "fade must be in (0, 1)";
  if (fade_repetitions < 1) return "fade_repetitions must be >= 1";
  if (check_every < 1) return "check_every must be >= 1";
  if (!(amplify > 0 && amplify <= 1)) return "amplify must be in (0, 1]";
  return {};
}

LessonPlan plan_next(const std::vector<PastSession>& h, const PlanOptions& o) {
  LessonPlan p;
  if (h.empty()) {
    p.mode = 1;
    p.level = "novice";
    p.level_from = "no data";
    p.rule = "first";
    p.reason = "No sessions yet: watch the expert's procedure first in mode 1 (visual replay), from any viewpoint.";
    return p;
  }
  const PastSession& last = h.back();

  // The student's level: the newest assessment, else the newest score, else novice.
  const PastSession* assessed = nullptr;
  const PastSession* scored = nullptr;
  for (auto it = h.rbegin(); it != h.rend(); ++it) {
    if (!assessed && !it->skill.empty()) assessed = &*it;
    // Only a session in which the student cut scores the student: in modes 1-4 the expert's
    // bur cuts and the student's does not, so their score is the expert's.
    if (!scored && it->has_score && it->max_points > 0 && (it->mode == 0 || it->mode == 5)) scored = &*it;
  }
  std::string why_level;
  if (assessed) {
    p.level = assessed->skill == "expert" ? "skilled" : assessed->skill == "intermediate" ? "intermediate" : "novice";
    p.level_from = "assessment";
    why_level = "the assessment rates the motion " + assessed->skill;
    // A skilled motion with a failing cut is not yet skilled at this task.
    if (p.level == "skilled" && scored && scored->score_fraction() < o.novice_score) {
      p.level = "intermediate";
      why_level += " but the cut scored " + pct(scored->score_fraction());
    }
  } else if (scored) {
    const double f = scored->score_fraction();
    p.level = f < o.novice_score ? "novice" : f >= o.skilled_score ? "skilled" : "intermediate";
    p.level_from = "score";
    why_level = "the last score was " + pct(f);
  } else {
    p.level = "novice";
    p.level_from = "no data";
    why_level = "there is no score or assessment yet";
  }

  const PastSession* f = last_following(h);
  const double e = f ? f->follow_mean_m : 0;
  const std::string err = f ? "the mean following error in " + std::string(mode_label(f->mode)) + " was " + mm(e) : "";
  haptics::GuidanceParams g;  // the seed's fixed field
  auto say = [&](const std::string& rule, int mode, const std::string& because) {
    p.rule = rule;
    p.mode = mode;
    p.reason = "Next: " + std::string(mode_label(mode)) + ", because " + because + ".";
  };

  if (p.level == "novice") {
    // Guided sessions in a row at the end of the history, and whether the last session was an
    // unguided check trial (mode 3 right after a guided one): practice fading (PlanOptions).
    int guided_run = 0;
    for (auto it = h.rbegin(); it != h.rend() && it->mode == 2; ++it) ++guided_run;
    const bool after_check =
        f == &last && last.mode == 3 && h.size() >= 2 && h[h.size() - 2].mode == 2;
    const int pre_check_rep = after_check ? h[h.size() - 2].guidance.repetition : 0;
    const std::string checks = "an unguided check trial after every " +
                               std::to_string(o.check_every) + " guided session" +
                               (o.check_every == 1 ? "" : "s");
    auto fade_to = [&](int rep) {
      g.as_needed = true;
      g.fade = o.fade;
      g.repetition = rep;
    };
    if (f && f->mode == 2 && e <= o.on_path_m) {
      const int rep = f->guidance.repetition + 1;
      if (rep > o.fade_repetitions) {
        say("novice_unguided", 3,
            why_level + " and " + err + " with guidance faded " + std::to_string(f->guidance.repetition) +
                " times: an unguided trial (the expert waits for you) shows what you keep without the field");
      } else {
        fade_to(rep);
        say("novice_fade", 2,
            why_level + " and " + err + " (on the path): the guidance fades (repetition " + std::to_string(rep) +
                ") and acts only as needed, so you do more of the work");
      }
    } else if (f == &last && last.mode == 2 && guided_run >= o.check_every) {
      // Guided check_every times in a row without reaching the path: guidance fades with
      // practice, so an unguided trial shows what the field taught and decides the next level.
      say("novice_check", 3,
          why_level + " and " + err + " after " + std::to_string(guided_run) +
              " guided sessions in a row: " + checks +
              " (the expert waits for you) shows what you keep without the field; constant "
              "guidance is learned less well than guidance that fades with practice");
    } else if (f && f->mode == 2 && f->guidance.repetition > 0 && e > o.strayed_m) {
      // Faded and strayed: one step less fading (adaptive fading), not the full field again.
      fade_to(f->guidance.repetition - 1);
      say("novice_fade_back", 2,
          why_level + " and " + err + " (strayed beyond " + mm(o.strayed_m) +
              " with guidance faded " + std::to_string(f->guidance.repetition) +
              " times): one step less fading (repetition " + std::to_string(g.repetition) +
              "), still as needed");
    } else if (f && f->mode == 2 && f->guidance.repetition > 0) {
      fade_to(f->guidance.repetition);
      say("novice_fade_hold", 2,
          why_level + " and " + err + " (off the path, within " + mm(o.strayed_m) +
              ") with guidance faded " + std::to_string(f->guidance.repetition) +
              " times: the same faded guidance, as needed, until " + checks +
              " decides whether it fades further");
    } else if (f && f->mode == 3 && e > o.strayed_m) {
      g.as_needed = true;
      say("novice_back_to_guidance", 2, why_level + " and " + err + " (strayed beyond " + mm(o.strayed_m) +
                                           "): guidance as needed brings the hand back to the path");
    } else if (after_check && e > o.close_m && pre_check_rep + 1 <= o.fade_repetitions) {
      fade_to(pre_check_rep + 1);
      say("novice_fade_practice", 2,
          why_level + " and " + err + " in the unguided check trial (within " + mm(o.strayed_m) +
              "): the guidance fades with practice (repetition " + std::to_string(g.repetition) +
              ") and acts only as needed, though the guided error stays above " + mm(o.on_path_m) +
              "; faded guidance is learned better than constant guidance");
    } else if (after_check) {
      say("novice_follow_again", 3,
          why_level + " and " + err + " in the unguided check trial" +
              (e <= o.close_m
                   ? " (close: within " + mm(o.close_m) + ")"
                   : " with guidance already faded " + std::to_string(pre_check_rep) + " times") +
              ": follow the expert without guidance until the error is below " + mm(o.close_m));
    } else if (f && f->mode == 3) {
      say("novice_follow_again", 3, why_level + " and " + err + ": follow the expert again until the error is below " +
                                        mm(o.close_m));
    } else {
      say("novice_guidance", 2,
          why_level + (f ? " and " + err : std::string(" and you have not been guided yet")) +
              ": full guidance helps novices learn the path" +
              (f && f->mode == 2 ? ", until " + checks + " lets it fade with practice"
                                 : std::string()));
    }
  } else if (p.level == "intermediate") {
    if (f && e > o.strayed_m) {
      g.as_needed = true;
      g.across_path_only = true;
      say("intermediate_guidance", 2,
          why_level + " and " + err + ": guidance as needed, only across the path (free along it), constrains just "
                                      "the direction that matters");
    } else if (f && e <= o.close_m && f->mode == 4) {
      say("intermediate_hints", 5, why_level + " and " + err +
                                       " after the expert's forces: cut on your own with the expert's tool shown");
    } else if (f && e <= o.close_m && scored && scored->score_fraction() < o.skilled_score) {
      say("intermediate_forces", 4, why_level + " and " + err +
                                        " (you follow the path) but the cut scores below " + pct(o.skilled_score) +
                                        ": push with the expert's force to learn how hard to press");
    } else if (f && e <= o.close_m) {
      say("intermediate_hints", 5, why_level + " and " + err + ": cut on your own with the expert's tool shown");
    } else {
      say("intermediate_follow", 3,
          why_level + (f ? " and " + err : std::string(" and you have not followed the expert yet")) +
              ": follow the expert actively; it waits while you are off the path");
    }
  } else {  // skilled
    if (last.mode == 2 && last.guidance.amplify > 0) {
      say("skilled_unguided", 5, why_level + " and the last session amplified your error: an unguided trial with the "
                                             "expert shown checks what stayed");
    } else if (!f || e <= o.close_m) {
      g.amplify = o.amplify;
      say("skilled_amplify", 2,
          why_level + (f ? " and " + err : std::string()) +
              ": error amplification (the field pushes you off the path) helps skilled learners correct themselves");
    } else {
      say("skilled_follow", 3, why_level + " but " + err + ": follow the expert first, then amplification");
    }
  }
  p.guidance = g;
  return p;
}

Result<PastSession> read_past_session(const std::string& path, const SkillModel* model) {
  PastSession s;
  s.path = path;
  std::error_code ec;
  const bool dir = fs::is_directory(path, ec);
  const fs::path log_path = dir ? fs::path(path) / "session.dlog" : fs::path(path);
  const fs::path folder = dir ? fs::path(path) : fs::path(path).parent_path();
  if (!fs::exists(log_path, ec))
    return Error{path + ": no session log (give a session folder holding session.dlog, or a .dlog)"};
  auto log = haptics::read_session_log(log_path.string());
  if (!log) return Error{log.error()};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{log_path.string() + ": " + setup.error()};
  if (setup->training) {
    s.mode = static_cast<int>(setup->training->params.mode);
    s.guidance = setup->training->params.guidance;
  }
  const auto read_json = [](const fs::path& p, json& out) -> std::string {
    std::ifstream f(p);
    if (!f) return {};
    out = json::parse(f, nullptr, false);
    if (out.is_discarded() || !out.is_object()) return p.string() + ": not a JSON object";
    return "ok";
  };
  json run, score;
  if (auto r = read_json(folder / "run.json", run); r == "ok") {
    const auto fe = run.find("follow_error_mm");
    if (fe == run.end() || !fe->is_object() || !fe->contains("mean") || !(*fe)["mean"].is_number() ||
        !fe->contains("p95") || !(*fe)["p95"].is_number())
      return Error{(folder / "run.json").string() + ": field follow_error_mm {mean, p95} (mm) is missing or not numbers"};
    s.has_follow = true;
    s.follow_from = "run.json";
    s.follow_mean_m = (*fe)["mean"].get<double>() * 1e-3;
    s.follow_p95_m = (*fe)["p95"].get<double>() * 1e-3;
    if (!(std::isfinite(s.follow_mean_m) && s.follow_mean_m >= 0))
      return Error{(folder / "run.json").string() + ": follow_error_mm.mean must be a finite number >= 0"};
  } else if (!r.empty()) {
    return Error{r};
  } else if (setup->training && s.mode >= 2 && s.mode <= 4) {
    if (Status st = replay_follow_error(*log, *setup, log_path.string(), s); !st) return Error{st.error()};
  }
  if (auto r = read_json(folder / "score.json", score); r == "ok") {
    const auto oc = score.find("outcome");
    if (oc == score.end() || !oc->is_object() || !oc->contains("points") || !(*oc)["points"].is_number() ||
        !oc->contains("max_points") || !(*oc)["max_points"].is_number())
      return Error{(folder / "score.json").string() + ": field outcome {points, max_points} is missing or not numbers"};
    s.has_score = true;
    s.points = (*oc)["points"].get<double>();
    s.max_points = (*oc)["max_points"].get<double>();
    if (!(s.max_points > 0 && s.points >= 0 && s.points <= s.max_points + 1e-9))
      return Error{(folder / "score.json").string() + ": outcome.points must be within 0..max_points (> 0)"};
    // The finish step's assessment (scored with a skill model).
    if (const auto as = score.find("assessment"); as != score.end()) {
      if (!as->is_object() || !as->contains("label") || !(*as)["label"].is_string())
        return Error{(folder / "score.json").string() + ": field assessment.label is missing or not a string"};
      s.skill = (*as)["label"].get<std::string>();
    }
  } else if (!r.empty()) {
    return Error{r};
  }
  if (model != nullptr) {
    auto t = decode_session(*log, log_path.string());
    if (!t) return Error{t.error()};
    auto v = classify(*model, track_features(*t), t->rate_hz);
    if (!v) return Error{log_path.string() + ": assessment: " + v.error()};
    s.skill = v->label;
  }
  return s;
}

std::string lesson_plan_json(const LessonPlan& p) {
  const auto& g = p.guidance;
  json j = {{"version", 1},
            {"mode", p.mode},
            {"level", p.level},
            {"level_from", p.level_from},
            {"rule", p.rule},
            {"reason", p.reason},
            {"guidance",
             {{"as_needed", g.as_needed},
              {"across_path_only", g.across_path_only},
              {"fade", g.fade},
              {"repetition", g.repetition},
              {"amplify", g.amplify}}},
            {"conditional_replay", p.conditional_replay}};
  return j.dump(1) + "\n";
}

Result<LessonPlan> parse_lesson_plan(const std::string& text, const std::string& name) {
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Error{name + ": not a JSON object (a plan.json from dentar lesson plan)"};
  LessonPlan p;
  try {
    if (j.value("version", 0) != 1) return Error{name + ": field version must be 1"};
    p.mode = j.at("mode").get<int>();
    if (p.mode < 1 || p.mode > 5) return Error{name + ": field mode = " + std::to_string(p.mode) + " must be 1..5"};
    p.level = j.value("level", "");
    p.level_from = j.value("level_from", "");
    p.rule = j.value("rule", "");
    p.reason = j.value("reason", "");
    const json& g = j.at("guidance");
    p.guidance.as_needed = g.at("as_needed").get<bool>();
    p.guidance.across_path_only = g.at("across_path_only").get<bool>();
    p.guidance.fade = g.at("fade").get<double>();
    p.guidance.repetition = g.at("repetition").get<int>();
    p.guidance.amplify = g.at("amplify").get<double>();
    p.conditional_replay = j.at("conditional_replay").get<bool>();
  } catch (const json::exception& e) {
    return Error{name + ": " + e.what() + " (fields: version, mode, guidance{as_needed, across_path_only, fade, "
                                          "repetition, amplify}, conditional_replay)"};
  }
  if (std::string v = p.guidance.validate(); !v.empty()) return Error{name + ": guidance: " + v};
  return p;
}

}  // namespace dentar::training
