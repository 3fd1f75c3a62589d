// dentar assess: skill assessment (discrete HMM, Gaussian HMM, DTW):
// generate a cohort, train with leave-one-subject-out cross-validation, save
// a model, classify sessions or kinematics tables, build an expert reference.
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
  int experts = 5, novices = 5, trials = 3;
  double separation = 1.0, voxel_mm = 0.15;
  std::uint64_t seed = 1;
};

Result<Trial> session_trial(const std::string& path, const std::string& subject, const std::string& label, int trial) {
  auto log = haptics::read_session_log(path);
  if (!log) return Error{log.error()};
  if (!log->warning.empty()) std::cerr << "dentar assess: warning: " << log->warning << "\n";
  auto t = decode_session(*log, path);
  if (!t) return Error{t.error()};
  return Trial{subject, label, path, trial, track_features(*t)};
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
  if (std::string why = o.validate(); !why.empty()) {
    print_error("assess", why);
    return 2;
  }
  if (!c.generate.empty()) {
    auto ex = c.exercise.find(".json") != std::string::npos ? load_exercise(c.exercise) : load_builtin_exercise(c.exercise);
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
    auto t = generate_cohort(*ex, co, c.generate);
    if (!t) {
      print_error("assess", t.error());
      return 1;
    }
    std::cout << "generated " << t->size() << " sessions of '" << ex->name << "' in " << c.generate << " (trials.csv)\n";
  }
  std::vector<Trial> trials;
  std::vector<std::string> names = track_feature_names();
  if (!c.train.empty()) {
    auto cohort = read_cohort(c.train);
    if (!cohort) {
      print_error("assess", cohort.error());
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
    auto t = import_trials(c.kinematics, *map, &names);
    if (!t) {
      print_error("assess", t.error());
      return 2;
    }
    trials = std::move(*t);
  }
  if (!c.make_reference.empty()) {
    auto ex = c.exercise.find(".json") != std::string::npos ? load_exercise(c.exercise) : load_builtin_exercise(c.exercise);
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
    if (c.cv != "subject") {
      print_error("assess", "--cv: only 'subject' (leave-one-subject-out) is supported");
      return 2;
    }
    if (trials.empty()) {
      print_error("assess", "--cv needs --train DIR or --kinematics TRIALS.csv");
      return 2;
    }
    auto r = cross_validate_subjects(trials, names, o);
    if (!r) {
      print_error("assess", r.error());
      return 1;
    }
    std::cout << std::fixed << std::setprecision(1) << "method " << method_name(o.method) << ", leave-one-subject-out: accuracy "
              << 100 * r->accuracy << " % (" << r->correct << "/" << r->n << "), 95 % CI [" << 100 * r->ci_low << ", "
              << 100 * r->ci_high << "] %\nconfusion (rows: true, columns: predicted)\n" << std::setw(12) << "";
    for (const auto& l : r->labels) std::cout << std::setw(10) << l;
    std::cout << "\n";
    for (std::size_t i = 0; i < r->labels.size(); ++i) {
      std::cout << std::setw(12) << r->labels[i];
      for (int v : r->confusion[i]) std::cout << std::setw(10) << v;
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
        else t = Trial{"", "", path, 0, k->x};
      }
      if (!t) {
        print_error("assess", t.error());
        return 2;
      }
      auto v = classify(*model, t->x);
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
      "          dentar assess --train DIR --cv subject [--method hmm|ghmm|dtw] [--save MODEL.json]\n"
      "          dentar assess --kinematics TRIALS.csv --columns MAP.json --cv subject\n"
      "          dentar assess --model MODEL.json SESSION...\n"
      "          dentar assess --train DIR --make-reference REF.json [--exercise NAME]");
  s->add_option("sessions", c->sessions, "Sessions to classify with --model (.dlog, folders, or tables with --columns)");
  s->add_option("--generate", c->generate, "Generate a cohort of expert and novice sessions into DIR");
  s->add_option("--train", c->train, "Cohort folder with trials.csv (file,subject,trial,label) and session logs");
  s->add_option("--kinematics", c->kinematics, "Trials table (file,subject,trial,label) of kinematics tables");
  s->add_option("--columns", c->columns, "Column map JSON for kinematics tables");
  s->add_option("--cv", c->cv, "Cross-validation: 'subject' (leave one subject out)");
  s->add_option("--save", c->save, "Train on all trials and save the model (JSON)");
  s->add_option("--model", c->model, "Classify SESSION... with this model");
  s->add_option("--make-reference", c->make_reference, "Write the expert reference (feedback statistics) of --train's experts");
  s->add_option("--exercise", c->exercise, "Exercise for --generate / --make-reference")->capture_default_str();
  s->add_option("--method", c->method, "hmm, ghmm or dtw")->capture_default_str();
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
      "  dentar assess --train out/cohort --cv subject --method hmm --save out/hmm.json\n"
      "  dentar assess --model out/hmm.json out/demo");
  s->callback([c, &exit_code] { exit_code = run_assess(*c); });
}

}  // namespace dentar::tools
