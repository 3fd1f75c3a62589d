// dentar assess: skill assessment (discrete HMM, Gaussian HMM, DTW):
// generate a cohort, train with leave-one-subject-out cross-validation, save
// a model, classify sessions or kinematics tables, build an expert reference.
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "commands.h"
#include "dentar/training/assess.h"
#include "dentar/training/cohort.h"
#include "dentar/training/feedback.h"
#include "dentar/training/kinematics.h"
#include "dentar/training/session.h"

namespace dentar::tools {
namespace {

using namespace dentar::training;

struct AssessCli {
  std::string generate, train, kinematics, columns, cv, save, model, make_reference, exercise = "molar_access_opening";
  std::vector<std::string> sessions;
  std::string method = "hmm";
  int states = 13, symbols = 13, iterations = 30;
  int experts = 5, novices = 5, trials = 3, intermediates = 0, decimate = 1;
  double separation = 1.0, voxel_mm = 0.15, style = 1.0;
  bool kinematics_only = false, normalise = false, no_identity = false;
  std::uint64_t seed = 1;
};

Result<Trial> session_trial(const std::string& path, const std::string& subject, const std::string& label, int trial) {
  auto log = haptics::read_session_log(path);
  if (!log) return Error{log.error()};
  if (!log->warning.empty()) std::cerr << "dentar assess: warning: " << log->warning << "\n";
  auto t = decode_session(*log, path);
  if (!t) return Error{t.error()};
  return Trial{subject, label, path, trial, track_features(*t), t->rate_hz};
}

int run_assess(const AssessCli& c) {
  AssessOptions o;
  auto m = parse_method(c.method);
  if (!m) {
    print_error("assess", "--method: " + m.error());
    return 2;
  }
  o.method = *m;
  o.states = c.states;
  o.symbols = c.symbols;
  o.iterations = c.iterations;
  o.seed = c.seed;
  o.normalise = c.normalise;
  o.decimate = c.decimate;
  if (std::string why = o.validate(); !why.empty()) {
    print_error("assess", why);
    return 2;
  }
  if (!c.generate.empty()) {
    auto ex = load_named_exercise(c.exercise);
    if (!ex) {
      print_error("assess", ex.error());
      return 2;
    }
    CohortOptions co;
    co.experts = c.experts;
    co.novices = c.novices;
    co.trials = c.trials;
    co.separation = c.separation;
    co.seed = c.seed;
    co.voxel_mm = c.voxel_mm;
    co.intermediates = c.intermediates;
    co.style = c.style;
    co.kinematics_only = c.kinematics_only;
    auto t = generate_cohort(*ex, co, c.generate);
    if (!t) {
      print_error("assess", t.error());
      return 1;
    }
    std::cout << "generated " << t->size() << (c.kinematics_only ? " kinematics tables" : " sessions") << " of '" << ex->name
              << "' in " << c.generate << " (trials.csv" << (c.kinematics_only ? ", columns.json" : "")
              << "), personal style " << c.style << "\n";
  }
  std::vector<Trial> trials;
  std::vector<std::string> names = track_feature_names();
  std::string trials_file;  // named in cross-validation errors
  if (!c.train.empty()) {
    auto cohort = read_cohort(c.train);
    if (!cohort) {
      print_error("assess", cohort.error());
      return 2;
    }
    trials_file = c.train + "/trials.csv";
    if (!cohort->empty() && cohort->front().session_path.size() > 4 &&
        cohort->front().session_path.substr(cohort->front().session_path.size() - 4) == ".csv") {
      print_error("assess", c.train + " holds kinematics tables (a --kinematics-only cohort): use --kinematics " +
                                c.train + "/trials.csv --columns " + c.train + "/columns.json");
      return 2;
    }
    for (const auto& ct : *cohort) {
      auto t = session_trial(ct.session_path, ct.subject, ct.label, ct.trial);
      if (!t) {
        print_error("assess", t.error());
        return 2;
      }
      trials.push_back(std::move(*t));
    }
  } else if (!c.kinematics.empty()) {
    if (c.columns.empty()) {
      print_error("assess", "--kinematics needs --columns MAP.json (the column map)");
      return 2;
    }
    auto map = load_column_map(c.columns);
    if (!map) {
      print_error("assess", map.error());
      return 2;
    }
    trials_file = c.kinematics;
    auto t = import_trials(c.kinematics, *map, &names);
    if (!t) {
      print_error("assess", t.error());
      return 2;
    }
    trials = std::move(*t);
  }
  if (!c.make_reference.empty()) {
    auto ex = load_named_exercise(c.exercise);
    if (!ex || c.train.empty()) {
      print_error("assess", ex ? "--make-reference needs --train DIR (its expert sessions)" : ex.error());
      return 2;
    }
    auto cohort = read_cohort(c.train);
    std::vector<ProcessMetrics> pm;
    for (const auto& ct : *cohort) {
      if (ct.label != "expert") continue;
      auto log = haptics::read_session_log(ct.session_path);
      auto tr = log ? decode_session(*log, ct.session_path) : Result<SessionTrack>(Error{log.error()});
      if (!tr) {
        print_error("assess", tr.error());
        return 2;
      }
      pm.push_back(process_metrics(*tr, *ex, segment_steps(*tr, *ex, nullptr, nullptr)));
    }
    if (pm.empty()) {
      print_error("assess", c.train + ": no trial labelled 'expert'");
      return 2;
    }
    std::ofstream(c.make_reference) << reference_to_json(build_reference(ex->name, pm)) << "\n";
    std::cout << "expert reference of " << pm.size() << " sessions: " << c.make_reference << "\n";
  }
  if (!c.cv.empty()) {
    if (c.cv != "subject" && c.cv != "trial") {
      print_error("assess", "--cv: '" + c.cv + "' is not a mode: subject (leave one person out) or trial (leave the k-th trial "
                            "of every person out)");
      return 2;
    }
    if (trials.empty()) {
      print_error("assess", "--cv needs --train DIR or --kinematics TRIALS.csv");
      return 2;
    }
    const auto t0 = std::chrono::steady_clock::now();
    auto r = cross_validate(trials, names, o, c.cv == "subject" ? CvMode::kSubject : CvMode::kTrial);
    if (!r) {
      // A fold without a label, too few persons: the input, not the job.
      print_error("assess", trials_file + ": " + r.error());
      return 2;
    }
    const double cv_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::cout << std::fixed << std::setprecision(1) << "method " << method_name(o.method)
              << (o.normalise ? " (per-trial normalisation)" : "")
              << (c.cv == "subject" ? ", leave-one-subject-out: accuracy "
                                    : ", leave-one-trial-out (the k-th trial of every person): accuracy ")
              << 100 * r->accuracy << " % (" << r->correct << "/" << r->n << "), 95 % CI [" << 100 * r->ci_low << ", "
              << 100 * r->ci_high << "] %, " << std::setprecision(2) << cv_s << " s\n" << std::setprecision(1);
    if (c.cv == "trial")
      std::cout << "note: the left-out trial's person is in training: this accuracy can measure who is operating, not how "
                   "well; a new student is measured by --cv subject\n";
    if (!c.no_identity) {
      auto id = cross_validate(trials, names, o, CvMode::kIdentity);
      if (id)
        std::cout << "person identification with the same features and method (leakage check, chance "
                  << 100.0 / static_cast<double>(id->labels.size()) << " %): " << 100 * id->accuracy << " % (" << id->correct
                  << "/" << id->n << "), 95 % CI [" << 100 * id->ci_low << ", " << 100 * id->ci_high << "] %\n";
      else
        std::cout << "person identification not measured: " << id.error() << "\n";
    }
    std::cout << "confusion (rows: true, columns: predicted)\n" << std::setw(14) << "";
    for (const auto& l : r->labels) std::cout << std::setw(14) << l;
    std::cout << "\n";
    for (std::size_t i = 0; i < r->labels.size(); ++i) {
      std::cout << std::setw(14) << r->labels[i];
      for (int v : r->confusion[i]) std::cout << std::setw(14) << v;
      std::cout << "\n";
    }
  }
  if (!c.save.empty()) {
    if (trials.empty()) {
      print_error("assess", "--save needs --train DIR or --kinematics TRIALS.csv");
      return 2;
    }
    auto model = train_model(trials, names, o);
    if (!model) {
      print_error("assess", model.error());
      return 1;
    }
    std::ofstream f(c.save);
    if (!(f << model_to_json(*model) << "\n")) {
      print_error("assess", c.save + ": cannot write the model");
      return 1;
    }
    std::cout << "model (" << method_name(o.method) << ", " << model->labels.size() << " labels, " << trials.size()
              << " trials) saved to " << c.save << "\n";
  }
  if (!c.model.empty()) {
    std::ifstream f(c.model);
    if (!f) {
      print_error("assess", c.model + ": cannot open the model");
      return 2;
    }
    std::stringstream ss;
    ss << f.rdbuf();
    auto model = model_from_json(ss.str(), c.model);
    if (!model) {
      print_error("assess", model.error());
      return 2;
    }
    if (c.sessions.empty()) {
      print_error("assess", "--model needs one or more SESSION arguments (.dlog files or session folders)");
      return 2;
    }
    for (const auto& s : c.sessions) {
      std::string path = s;
      if (std::ifstream(path + "/session.dlog")) path += "/session.dlog";
      Result<Trial> t = Error{""};
      if (path.size() > 5 && path.substr(path.size() - 5) == ".dlog") {
        t = session_trial(path, "", "", 0);
      } else {
        if (c.columns.empty()) {
          print_error("assess", s + ": not a .dlog; give --columns MAP.json to read it as a kinematics table");
          return 2;
        }
        auto map = load_column_map(c.columns);
        if (!map) {
          print_error("assess", map.error());
          return 2;
        }
        auto k = read_kinematics(path, *map);
        if (!k) t = Error{k.error()};
        else t = Trial{"", "", path, 0, k->x, k->rate_hz};
      }
      if (!t) {
        print_error("assess", t.error());
        return 2;
      }
      auto v = classify(*model, t->x, t->rate_hz);
      if (!v) {
        print_error("assess", s + ": " + v.error());
        return 2;
      }
      std::cout << s << ": " << v->label << " (score margin " << std::setprecision(3) << v->margin << ")\n";
    }
  }
  if (c.generate.empty() && c.train.empty() && c.kinematics.empty() && c.model.empty()) {
    print_error("assess", "nothing to do: give --generate DIR, --train DIR, --kinematics TRIALS.csv or --model FILE (see --help)");
    return 2;
  }
  return 0;
}

}  // namespace

void add_assess(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<AssessCli>();
  CLI::App* s = app.add_subcommand(
      "assess",
      "Skill assessment with a discrete HMM (k-means symbols), a Gaussian HMM or DTW.\n"
      "Synopsis: dentar assess --generate DIR [--experts N --novices N --trials N --separation S]\n"
      "                               [--intermediates N --style S --kinematics-only]\n"
      "          dentar assess --train DIR --cv subject|trial [--method M] [--normalise] [--save MODEL.json]\n"
      "          dentar assess --kinematics TRIALS.csv --columns MAP.json --cv subject|trial [--method M]\n"
      "Methods: hmm (the seed's discrete HMM), ghmm, dtw (on frames); skill (per-trial skill features, nearest\n"
      "centroid), skill-lda (the same in units of the within-class SD: diagonal LDA); time, timepath (baselines:\n"
      "task time; task time and path length).\n"
      "--cv subject leaves one person out (a new student); --cv trial leaves the k-th trial of every person out, so\n"
      "the person stays in training and the accuracy can measure identity. Both print person identification\n"
      "(the same features and method told to name the person) as a leakage check.\n"
      "          dentar assess --model MODEL.json SESSION...\n"
      "          dentar assess --train DIR --make-reference REF.json [--exercise NAME]");
  s->add_option("sessions", c->sessions, "Sessions to classify with --model (.dlog, folders, or tables with --columns)");
  s->add_option("--generate", c->generate, "Generate a cohort of expert and novice sessions into DIR");
  s->add_option("--train", c->train, "Cohort folder with trials.csv (file,subject,trial,label) and session logs");
  s->add_option("--kinematics", c->kinematics, "Trials table (file,subject,trial,label) of kinematics tables");
  s->add_option("--columns", c->columns, "Column map JSON for kinematics tables");
  s->add_option("--cv", c->cv, "Cross-validation: 'subject' (leave one person out) or 'trial' (leave the k-th trial of "
                                "every person out; can measure identity)");
  s->add_flag("--normalise", c->normalise, "Sequence methods: per-trial normalisation (posture, orientation, force level, speed)");
  s->add_option("--decimate", c->decimate, "Sequence methods: keep every n-th frame")->capture_default_str();
  s->add_flag("--no-identity", c->no_identity, "Skip the person-identification check after --cv");
  s->add_option("--intermediates", c->intermediates, "Intermediate subjects, a third class (--generate)")->capture_default_str();
  s->add_option("--style", c->style, "Personal style strength: 0 none, 1 documented (--generate)")
      ->check(CLI::Range(0.0, 3.0))
      ->capture_default_str();
  s->add_flag("--kinematics-only", c->kinematics_only,
              "Write 100 Hz kinematics tables (bur and mirror hands) instead of engine sessions (--generate)");
  s->add_option("--save", c->save, "Train on all trials and save the model (JSON)");
  s->add_option("--model", c->model, "Classify SESSION... with this model");
  s->add_option("--make-reference", c->make_reference, "Write the expert reference (feedback statistics) of --train's experts");
  s->add_option("--exercise", c->exercise, "Exercise for --generate / --make-reference")->capture_default_str();
  s->add_option("--method", c->method, "hmm, ghmm, dtw, skill, skill-lda, time or timepath")->capture_default_str();
  s->add_option("--states", c->states, "Hidden states")->capture_default_str();
  s->add_option("--symbols", c->symbols, "k-means symbols (hmm)")->capture_default_str();
  s->add_option("--iterations", c->iterations, "Baum-Welch iterations at most")->capture_default_str();
  s->add_option("--experts", c->experts, "Expert subjects (--generate)")->capture_default_str();
  s->add_option("--novices", c->novices, "Novice subjects (--generate)")->capture_default_str();
  s->add_option("--trials", c->trials, "Trials per subject (--generate)")->capture_default_str();
  s->add_option("--separation", c->separation, "0 = identical classes .. 1 = fully apart (--generate)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  s->add_option("--voxel-mm", c->voxel_mm, "Voxel size of the generated sessions' tooth")->capture_default_str();
  s->add_option("--seed", c->seed, "Random seed")->capture_default_str();
  s->footer(
      "Example:\n  dentar assess --generate out/cohort --experts 5 --novices 5 --trials 2\n"
      "  dentar assess --generate out/kin --kinematics-only --experts 8 --intermediates 8 --novices 8\n"
      "  dentar assess --kinematics out/kin/trials.csv --columns out/kin/columns.json --cv subject --method skill\n"
      "  dentar assess --train out/cohort --cv subject --method hmm --save out/hmm.json\n"
      "  dentar assess --model out/hmm.json out/demo");
  s->callback([c, &exit_code] { exit_code = run_assess(*c); });
}

}  // namespace dentar::tools
