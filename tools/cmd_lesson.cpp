// dentar lesson: make a lesson from a recording, show it, ship the generated expert lessons
// of the built-in exercises, and run a lesson offline in a training mode with a simulated
// student (issue 27). The logic is in training/lesson.h and training/lesson_run.h.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <iostream>
#include <memory>
#include <optional>

#include "commands.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/lesson.h"
#include "dentar/training/lesson_plan.h"
#include "dentar/training/lesson_run.h"
#include "dentar/session/finish.h"

namespace dentar::tools {
namespace {

namespace fs = std::filesystem;

struct LessonArgs {
  std::string recording, exercise, out, title, lesson, device = "touch", student = "active";
  std::vector<std::string> notes, pauses;
  int mode = 0;
  std::uint64_t seed = 1;
  double seconds = 0, jitter_ms = 0, lag_s = -1, noise_mm = -1;
  bool no_score = false, no_pauses = false, generated = false;
  std::vector<std::string> exercises;
  std::vector<std::string> sessions;  // lesson plan: the student's recent sessions, oldest first
  std::string model, plan;            // lesson plan: skill model; lesson run: a plan.json to apply
  int check_every = training::PlanOptions{}.check_every;  // lesson plan: guided sessions per check trial
};

int do_make(const LessonArgs& a) {
  training::LessonMakeOptions o;
  o.exercise = a.exercise;
  o.title = a.title;
  for (const auto& n : a.notes) {
    auto x = training::parse_annotation_arg(n, false, "--note");
    if (!x) return print_error("lesson make", x.error()), 2;
    o.annotations.push_back(*x);
  }
  for (const auto& n : a.pauses) {
    auto x = training::parse_annotation_arg(n, true, "--pause");
    if (!x) return print_error("lesson make", x.error()), 2;
    o.annotations.push_back(*x);
  }
  if (a.generated && !a.recording.empty())
    return print_error("lesson make", "give either RECORDING or --generated, not both"), 2;
  if (!a.generated && a.recording.empty())
    return print_error("lesson make", "give the RECORDING (a session .dlog or a folder holding session.dlog), or --generated"), 2;
  auto l = a.generated ? training::make_generated_lesson(a.exercise, a.out, a.seed)
                       : training::make_lesson(a.recording, a.out, o);
  if (!l) return print_error("lesson make", l.error()), 2;
  if (a.generated && !o.annotations.empty())
    std::cout << "note: --note/--pause are ignored with --generated; add them to " << l->path << "/lesson.json\n";
  std::cout << training::describe_lesson(*l);
  return 0;
}

int do_builtin(const LessonArgs& a) {
  std::vector<std::string> names = a.exercises;
  if (names.empty()) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(training::builtin_exercise_dir(), ec))
      if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
  }
  if (names.empty()) return print_error("lesson builtin", "no built-in exercises found in " + training::builtin_exercise_dir()), 2;
  int made = 0;
  for (const auto& n : names) {
    const std::string out = (fs::path(a.out) / n).string();
    if (fs::exists(out)) {
      std::cout << "kept " << out << " (exists)\n";
      continue;
    }
    auto l = training::make_generated_lesson(n, out, a.seed);
    if (!l) return print_error("lesson builtin", n + ": " + l.error()), 2;
    std::cout << "made " << out << ": " << l->title << ", " << l->duration_s << " s, " << l->annotations.size()
              << " annotations\n";
    ++made;
  }
  std::cout << made << " lesson(s) made in " << a.out << "\n";
  return 0;
}

int do_show(const LessonArgs& a) {
  auto path = training::resolve_lesson_path(a.lesson);
  if (!path) return print_error("lesson show", path.error()), 2;
  auto l = training::load_lesson(*path);
  if (!l) return print_error("lesson show", l.error()), 2;
  std::cout << training::describe_lesson(*l);
  return 0;
}

int do_plan(const LessonArgs& a) {
  std::optional<training::SkillModel> model;
  if (!a.model.empty()) {
    std::ifstream f(a.model);
    if (!f) return print_error("lesson plan", a.model + ": cannot open the skill model (dentar assess --save)"), 2;
    std::stringstream ss;
    ss << f.rdbuf();
    auto m = training::model_from_json(ss.str(), a.model);
    if (!m) return print_error("lesson plan", m.error()), 2;
    model = std::move(*m);
  }
  training::PlanOptions po;
  po.check_every = a.check_every;
  if (std::string v = po.validate(); !v.empty())
    return print_error("lesson plan", "--check-every " + std::to_string(a.check_every) + ": " + v), 2;
  std::vector<training::PastSession> history;
  for (const auto& s : a.sessions) {
    auto p = training::read_past_session(s, model ? &*model : nullptr);
    if (!p) return print_error("lesson plan", p.error()), 2;
    std::printf("%s: %s", s.c_str(), p->mode == 0 ? "plain drilling" : ("mode " + std::to_string(p->mode)).c_str());
    if (p->has_follow) std::printf(", following error %.2f mm (p95 %.2f)", p->follow_mean_m * 1e3, p->follow_p95_m * 1e3);
    if (p->has_score) std::printf(", score %.1f / %.0f", p->points, p->max_points);
    if (!p->skill.empty()) std::printf(", assessed %s", p->skill.c_str());
    std::printf("\n");
    history.push_back(std::move(*p));
  }
  const training::LessonPlan plan = training::plan_next(history, po);
  std::cout << plan.reason << "\n";
  std::cout << "guidance: " << (plan.guidance.as_needed ? "as needed" : "fixed")
            << (plan.guidance.across_path_only ? ", across the path only" : "");
  if (plan.guidance.repetition > 0)
    std::printf(", faded %.2f^%d", plan.guidance.fade, plan.guidance.repetition);
  if (plan.guidance.amplify > 0) std::printf(", error amplification %.2f", plan.guidance.amplify);
  std::cout << " (level " << plan.level << ", from " << plan.level_from << ")\n";
  if (!a.out.empty()) {
    std::ofstream f(a.out);
    if (!(f << training::lesson_plan_json(plan)))
      return print_error("lesson plan", a.out + ": cannot write the plan"), 1;
    std::cout << "plan: " << a.out << " (dentar lesson run LESSON --plan " << a.out << " --out DIR)\n";
  }
  return 0;
}

int do_run(const LessonArgs& a) {
  training::LessonRunOptions o;
  std::optional<training::LessonPlan> plan;
  if (!a.plan.empty()) {
    std::ifstream f(a.plan);
    if (!f) return print_error("lesson run", a.plan + ": cannot open the plan (dentar lesson plan --out)"), 2;
    std::stringstream ss;
    ss << f.rdbuf();
    auto p = training::parse_lesson_plan(ss.str(), a.plan);
    if (!p) return print_error("lesson run", p.error()), 2;
    if (a.mode != 0 && a.mode != p->mode)
      return print_error("lesson run", "--mode " + std::to_string(a.mode) + " contradicts the plan's mode " +
                                           std::to_string(p->mode) + " (" + a.plan + "); give one of them"), 2;
    plan = *p;
  }
  o.mode = plan ? plan->mode : a.mode;
  if (o.mode == 0) return print_error("lesson run", "give --mode 1..5 or --plan PLAN.json"), 2;
  o.device = a.device;
  if (a.student == "passive")
    o.student = training::StudentModel::passive_hand();
  else if (a.student != "active")
    return print_error("lesson run", "--student '" + a.student + "' must be active or passive"), 2;
  o.student.seed = a.seed;
  if (a.lag_s >= 0) o.student.lag_s = a.lag_s;
  if (a.noise_mm >= 0) o.student.noise_mm = a.noise_mm;
  o.seconds = a.seconds;
  o.jitter_s = a.jitter_ms * 1e-3;
  o.pauses = !a.no_pauses;
  o.out_dir = a.out;
  if (std::string v = o.validate(); !v.empty()) return print_error("lesson run", v), 2;
  if (a.out.empty()) return print_error("lesson run", "--out DIR is required (the session is recorded there)"), 2;
  auto path = training::resolve_lesson_path(a.lesson);
  if (!path) return print_error("lesson run", path.error()), 2;
  auto l = training::load_lesson(*path);
  if (!l) return print_error("lesson run", l.error()), 2;
  if (plan) {
    // The plan's guidance on top of the lesson's field (its k, eps1, eps2 and damping stay).
    auto& g = l->params.guidance;
    g.as_needed = plan->guidance.as_needed;
    g.across_path_only = plan->guidance.across_path_only;
    g.fade = plan->guidance.fade;
    g.repetition = plan->guidance.repetition;
    g.amplify = plan->guidance.amplify;
    l->params.conditional_replay = plan->conditional_replay;
    std::cout << "plan: " << plan->reason << "\n";
  }
  if (fs::exists(fs::path(a.out) / "session.dlog"))
    return print_error("lesson run", a.out + " already holds a session.dlog; give a new --out folder"), 2;
  auto r = training::run_lesson(*l, o);
  if (!r) {
    std::error_code ec;
    fs::remove(fs::path(a.out) / "session.dlog", ec);
    fs::remove(fs::path(a.out) / "run.json", ec);
    print_error("lesson run", r.error());
    return r.error().rfind("--", 0) == 0 ? 2 : 1;
  }
  if (!r->fallback.empty()) std::cout << "note: " << r->fallback << "\n";
  for (const auto& n : r->notes) std::cout << "note: " << n << "\n";
  std::printf("mode %d (%s) on %s: %llu steps, expert at %.2f / %.2f s, waited %.2f s, %d pause(s)\n", r->mode_run,
              haptics::training_mode_name(static_cast<haptics::TrainingModeKind>(r->mode_run)), r->device.c_str(),
              static_cast<unsigned long long>(r->steps), r->expert_end_s, l->duration_s, r->waited_s, r->pauses_taken);
  std::printf("following error: mean %.3f mm, p95 %.3f mm; max force %.3f N; removed %.3f mm3\n", r->follow_mean_m * 1e3,
              r->follow_p95_m * 1e3, r->max_force_N, r->removed_mm3);
  std::cout << "session: " << r->session_path << "\n";
  // Replayable: the recording rebuilds the mode and recomputes both bur's cuts bit-exactly.
  {
    auto log = haptics::read_session_log(r->session_path);
    auto fresh = training::make_tooth(l->tooth_json);
    if (!log || !fresh) return print_error("lesson run", !log ? log.error() : fresh.error()), 1;
    auto rep = haptics::replay_session(*log, *fresh);
    if (!rep) return print_error("lesson run", "replay: " + rep.error()), 1;
    if (rep->volume_hash != r->volume_hash)
      return print_error("lesson run", "replay of " + r->session_path + " does not reproduce the run's volume"), 1;
    std::cout << "replay: " << rep->steps << " steps reproduce the run's volume bit-exactly\n";
  }
  if (!a.no_score) {
    session::DriverScoreInput in;
    in.session = r->session_path;
    in.out_dir = a.out;
    in.exercise = l->exercise;
    const session::DriverScore d = session::score_after_run(in);
    std::cout << (d.ok ? d.line : "warning: " + d.warning) << "\n";
  }
  return 0;
}

}  // namespace

void add_lesson(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<LessonArgs>();
  CLI::App* s = app.add_subcommand("lesson", "Lessons from an expert's recording: make, show, builtin, run, plan (issue 27)");
  s->require_subcommand(1);
  s->footer(
      "Examples:\n"
      "  dentar lesson builtin --out lessons\n"
      "  dentar lesson make rec/session.dlog --exercise molar_class1_cavity --out my_lesson --note 3.5:'enter here' "
      "--pause 10:2\n"
      "  dentar lesson show lessons/molar_class1_cavity\n"
      "  dentar lesson run builtin:molar_access_opening --mode 3 --out run3\n"
      "  dentar lesson run lessons/molar_class1_cavity --mode 2 --student passive --seed 3 --out run1\n"
      "  dentar lesson plan run1 --out plan.json\n"
      "Format: docs/formats.md (\"Lesson\"); modes: docs/training_modes.md");

  CLI::App* mk = s->add_subcommand("make", "Turn a recording into a lesson folder (lesson.json + expert.dlog)");
  mk->add_option("recording", a->recording, "Session .dlog, or a folder holding session.dlog (live --record, demo, cohort trial)");
  mk->add_option("--exercise", a->exercise, "Built-in exercise name or exercise .json")->required();
  mk->add_option("--out", a->out, "The lesson folder to create (must not exist)")->required();
  mk->add_option("--title", a->title, "Title (default: the exercise's)");
  mk->add_option("--note", a->notes, "Text annotation TIME_S:TEXT or @STEP:TEXT (repeatable)");
  mk->add_option("--pause", a->pauses, "Pause point TIME_S[:SECONDS] or @STEP[:SECONDS] (default 2 s; repeatable)");
  mk->add_flag("--generated", a->generated, "Use a generated expert of the exercise instead of a recording");
  mk->add_option("--seed", a->seed, "Seed of the generated expert")->capture_default_str();
  mk->callback([a, &exit_code] { exit_code = do_make(*a); });

  CLI::App* bi = s->add_subcommand("builtin", "Make the generated expert lesson of every built-in exercise (no download)");
  bi->add_option("--out", a->out, "Folder that receives one lesson per exercise")->required();
  bi->add_option("--exercise", a->exercises, "Only these exercises (repeatable)");
  bi->add_option("--seed", a->seed, "Seed of the generated experts")->capture_default_str();
  bi->callback([a, &exit_code] { exit_code = do_builtin(*a); });

  CLI::App* sh = s->add_subcommand("show", "Check a lesson (recording, hash, exercise) and print it");
  sh->add_option("lesson", a->lesson, "Lesson folder, its lesson.json, or builtin:EXERCISE (made in the cache on first use)")->required();
  sh->callback([a, &exit_code] { exit_code = do_show(*a); });

  CLI::App* rn = s->add_subcommand("run", "Run a lesson offline in a mode with a simulated student; record and score it");
  rn->add_option("lesson", a->lesson, "Lesson folder, its lesson.json, or builtin:EXERCISE (made in the cache on first use)")
      ->required();
  rn->add_option("--mode", a->mode, "1 visual replay, 2 passive guidance, 3 active following, 4 force reversal, 5 hints");
  rn->add_option("--plan", a->plan, "A plan.json from dentar lesson plan: its mode and guidance (instead of --mode)");
  rn->add_option("--student", a->student, "sim student: active (grips, follows with lag) or passive (relaxed hand)")
      ->capture_default_str();
  rn->add_option("--device", a->device, "Device profile (dentar devices --profiles) or pen (no force)")->capture_default_str();
  rn->add_option("--seed", a->seed, "Seed of the student's noise")->capture_default_str();
  rn->add_option("--lag", a->lag_s, "Student's reaction lag, s (default: 0.25 active, 0.5 passive)");
  rn->add_option("--noise-mm", a->noise_mm, "SD of the student's aim wander, mm (default 0.2)");
  rn->add_option("--seconds", a->seconds, "Stop at this expert time (default: the whole recording)");
  rn->add_option("--jitter-ms", a->jitter_ms, "Extra period length, uniform in [0, ms]")->capture_default_str();
  rn->add_flag("--no-pauses", a->no_pauses, "Ignore the lesson's pause points");
  rn->add_flag("--no-score", a->no_score, "Do not score the session");
  rn->add_option("--out", a->out, "Folder for session.dlog, run.json and the score")->required();
  rn->callback([a, &exit_code] { exit_code = do_run(*a); });

  CLI::App* pl = s->add_subcommand("plan", "Pick the next mode and guidance from a student's recent sessions, and say why");
  pl->add_option("sessions", a->sessions, "The student's recent session folders (or .dlog), oldest first");
  pl->add_option("--model", a->model, "Skill model (dentar assess --save) to assess each session's motion");
  pl->add_option("--out", a->out, "Write the plan here (plan.json; dentar lesson run --plan)");
  pl->add_option("--check-every", a->check_every,
                 "A novice guided this many sessions in a row off the path gets an unguided check trial")
      ->capture_default_str();
  pl->footer("Rules: docs/training_modes.md (\"The lesson plan\"). Example:\n"
             "  dentar lesson plan run1 run2 --out plan.json && dentar lesson run builtin:molar_class1_cavity --plan plan.json --out run3");
  pl->callback([a, &exit_code] { exit_code = do_plan(*a); });
}

}  // namespace dentar::tools
