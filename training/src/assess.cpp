#include "dentar/training/assess.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <limits>
#include <set>

#include "dentar/training/skill_features.h"

namespace dentar::training {
namespace {
bool is_summary(Method m) {
  return m == Method::kSkill || m == Method::kSkillLda || m == Method::kTime || m == Method::kTimePath;
}
SummarySet summary_set(Method m) {
  return m == Method::kTime ? SummarySet::kTime : m == Method::kTimePath ? SummarySet::kTimePath : SummarySet::kSkill;
}
// Sequence methods: per-trial normalisation and decimation.
Sequence prepare(const Sequence& x, const std::vector<std::string>& names, const AssessOptions& o) {
  Sequence y = o.normalise && static_cast<std::size_t>(x.cols()) == names.size() ? normalise_trial(x, names) : x;
  if (o.decimate <= 1 || y.rows() < 2 * o.decimate) return y;
  Sequence d((y.rows() + o.decimate - 1) / o.decimate, y.cols());
  for (Eigen::Index i = 0; i < d.rows(); ++i) d.row(i) = y.row(i * o.decimate);
  return d;
}
}  // namespace

std::string method_name(Method m) {
  switch (m) {
    case Method::kDiscreteHmm: return "hmm";
    case Method::kGaussianHmm: return "ghmm";
    case Method::kDtw: return "dtw";
    case Method::kSkill: return "skill";
    case Method::kSkillLda: return "skill-lda";
    case Method::kTime: return "time";
    case Method::kTimePath: return "timepath";
  }
  return "?";
}

Result<Method> parse_method(const std::string& s) {
  if (s == "hmm") return Method::kDiscreteHmm;
  if (s == "ghmm") return Method::kGaussianHmm;
  if (s == "dtw") return Method::kDtw;
  if (s == "skill") return Method::kSkill;
  if (s == "skill-lda") return Method::kSkillLda;
  if (s == "time") return Method::kTime;
  if (s == "timepath") return Method::kTimePath;
  return Error{"unknown method '" + s + "' (hmm, ghmm, dtw, skill, skill-lda, time, timepath)"};
}

std::string AssessOptions::validate() const {
  if (states < 1 || states > 100) return "states must be in [1, 100]";
  if (symbols < 1 || symbols > 1000) return "symbols must be in [1, 1000]";
  if (iterations < 1 || iterations > 1000) return "iterations must be in [1, 1000]";
  if (!(floor >= 0 && floor * symbols < 1)) return "floor must be in [0, 1/symbols)";
  if (!(var_floor > 0)) return "var_floor must be > 0";
  if (dtw_length < 2 || dtw_length > 100000) return "dtw_length must be in [2, 100000]";
  if (decimate < 1 || decimate > 1000) return "decimate must be in [1, 1000]";
  return {};
}

void wilson_interval(int k, int n, double& lo, double& hi) {
  if (n <= 0) {
    lo = 0;
    hi = 1;
    return;
  }
  const double z = 1.96, p = static_cast<double>(k) / n, z2n = z * z / n;
  const double c = (p + z2n / 2) / (1 + z2n);
  const double h = z * std::sqrt(p * (1 - p) / n + z * z / (4.0 * n * n)) / (1 + z2n);
  lo = std::max(0.0, c - h);
  hi = std::min(1.0, c + h);
}

namespace {
// Trials by pointer with their labels (cross-validation folds and person
// identification without copying the sequences).
Result<SkillModel> train_impl(const std::vector<const Trial*>& trials, const std::vector<std::string>& label_of,
                              const std::vector<std::string>& names, const AssessOptions& opt) {
  if (std::string why = opt.validate(); !why.empty()) return Error{"assessment options: " + why};
  if (trials.empty()) return Error{"assessment: no training trial"};
  SkillModel m;
  m.method = opt.method;
  m.options = opt;
  m.feature_names = names;
  std::set<std::string> labels;
  for (const auto& l : label_of) labels.insert(l);
  if (labels.size() < 2) return Error{"assessment: training needs trials of at least two skill labels (got only '" + *labels.begin() + "')"};
  m.labels.assign(labels.begin(), labels.end());
  if (is_summary(opt.method)) {
    const SummarySet set = summary_set(opt.method);
    const auto fn = summary_feature_names(set, names);
    Sequence F(static_cast<Eigen::Index>(trials.size()), static_cast<Eigen::Index>(fn.size()));
    for (std::size_t i = 0; i < trials.size(); ++i) {
      if (Status st = check_finite(trials[i]->x, trials[i]->source, names); !st) return Error{st.error()};
      auto f = summary_features(set, trials[i]->x, names, trials[i]->rate_hz);
      if (!f) return Error{"assessment: " + trials[i]->source + ": " + f.error()};
      F.row(static_cast<Eigen::Index>(i)) = f->transpose();
    }
    m.scaler.mean = F.colwise().mean().transpose();
    m.scaler.std = ((F.rowwise() - m.scaler.mean.transpose()).colwise().squaredNorm() /
                    std::max<double>(1.0, static_cast<double>(F.rows() - 1))).cwiseSqrt().transpose();
    if (opt.method == Method::kSkillLda) {
      // Diagonal LDA: each feature in units of its pooled within-class SD
      // (not the total SD), so a feature whose classes lie far apart for
      // their spread weighs more than one that mostly varies between persons
      // of a class. Equal priors, shared diagonal covariance.
      std::map<std::string, std::pair<Eigen::VectorXd, double>> cls;
      for (std::size_t i = 0; i < trials.size(); ++i) {
        auto& c = cls[label_of[i]];
        if (c.first.size() == 0) c.first = Eigen::VectorXd::Zero(F.cols());
        c.first += F.row(static_cast<Eigen::Index>(i)).transpose();
        c.second += 1;
      }
      Eigen::VectorXd ss = Eigen::VectorXd::Zero(F.cols());
      for (std::size_t i = 0; i < trials.size(); ++i) {
        const auto& c = cls[label_of[i]];
        ss += (F.row(static_cast<Eigen::Index>(i)).transpose() - c.first / c.second).cwiseAbs2();
      }
      const double dof = static_cast<double>(trials.size()) - static_cast<double>(cls.size());
      if (dof >= 1) m.scaler.std = (ss / dof).cwiseSqrt();
    }
    for (Eigen::Index k = 0; k < m.scaler.std.size(); ++k)
      if (!(m.scaler.std(k) > 1e-12)) m.scaler.std(k) = 1.0;  // constant over training: carries nothing
    const Sequence Z = m.scaler.apply(F);
    m.centroids = Sequence::Zero(static_cast<Eigen::Index>(m.labels.size()), Z.cols());
    for (std::size_t li = 0; li < m.labels.size(); ++li) {
      double n = 0;
      for (std::size_t i = 0; i < trials.size(); ++i)
        if (label_of[i] == m.labels[li]) {
          m.centroids.row(static_cast<Eigen::Index>(li)) += Z.row(static_cast<Eigen::Index>(i));
          n += 1;
        }
      m.centroids.row(static_cast<Eigen::Index>(li)) /= n;
    }
    return m;
  }
  std::vector<Sequence> raw;
  for (const Trial* t : trials) {
    if (t->x.rows() < 2) return Error{"assessment: trial " + t->source + " has fewer than 2 frames"};
    if (Status st = check_finite(t->x, t->source, names); !st) return Error{st.error()};
    raw.push_back(prepare(t->x, names, opt));
  }
  auto sc = ZScaler::fit(raw, names);
  if (!sc) return Error{"assessment: " + sc.error()};
  m.scaler = *sc;
  std::vector<Sequence> z;
  for (const auto& r : raw) z.push_back(m.scaler.apply(r));
  if (opt.method == Method::kDiscreteHmm) {
    Eigen::Index rows = 0;
    for (const auto& s : z) rows += s.rows();
    Sequence all(rows, z[0].cols());
    rows = 0;
    for (const auto& s : z) {
      all.middleRows(rows, s.rows()) = s;
      rows += s.rows();
    }
    auto km = KMeans::fit(all, opt.symbols, opt.seed);
    if (!km) return Error{"assessment: vector quantisation: " + km.error()};
    m.codebook = *km;
  }
  for (std::size_t li = 0; li < m.labels.size(); ++li) {
    std::vector<Sequence> mine;
    for (std::size_t i = 0; i < trials.size(); ++i)
      if (label_of[i] == m.labels[li]) mine.push_back(z[i]);
    switch (opt.method) {
      case Method::kDiscreteHmm: {
        std::vector<std::vector<int>> sym;
        for (const auto& s : mine) sym.push_back(m.codebook.quantise(s));
        DiscreteHmm h = DiscreteHmm::random(opt.states, opt.symbols, opt.seed + li, opt.floor);
        auto rep = h.train(sym, opt.iterations);
        if (!rep) return Error{"assessment: label '" + m.labels[li] + "': " + rep.error()};
        m.dhmm.push_back(h);
        break;
      }
      case Method::kGaussianHmm: {
        auto g = GaussianHmm::init(mine, opt.states, opt.seed + li);
        if (!g) return Error{"assessment: label '" + m.labels[li] + "': " + g.error()};
        g->var_floor = opt.var_floor;
        g->var = g->var.cwiseMax(opt.var_floor);
        auto rep = g->train(mine, opt.iterations);
        if (!rep) return Error{"assessment: label '" + m.labels[li] + "': " + rep.error()};
        m.ghmm.push_back(*g);
        break;
      }
      case Method::kDtw: {
        std::vector<Sequence> tpl;
        for (const auto& s : mine) tpl.push_back(resample(s, opt.dtw_length));
        m.templates.push_back(tpl);
        break;
      }
      case Method::kSkill:
      case Method::kSkillLda:
      case Method::kTime:
      case Method::kTimePath: break;  // handled above
    }
  }
  return m;
}
}  // namespace

Result<SkillModel> train_model(const std::vector<Trial>& trials, const std::vector<std::string>& names,
                               const AssessOptions& opt) {
  std::vector<const Trial*> p;
  std::vector<std::string> l;
  for (const auto& t : trials) {
    p.push_back(&t);
    l.push_back(t.label);
  }
  return train_impl(p, l, names, opt);
}

Result<Verdict> classify(const SkillModel& m, const Sequence& x_in, double rate_hz) {
  if (x_in.rows() < 1) return Error{"classify: empty sequence"};
  if (is_summary(m.method)) {
    if (static_cast<std::size_t>(x_in.cols()) != m.feature_names.size())
      return Error{"classify: the sequence has " + std::to_string(x_in.cols()) + " columns, the model expects " +
                   std::to_string(m.feature_names.size())};
    if (Status st = check_finite(x_in, "classify", m.feature_names); !st) return Error{st.error()};
    auto f = summary_features(summary_set(m.method), x_in, m.feature_names, rate_hz);
    if (!f) return Error{"classify: " + f.error()};
    if (f->size() != m.scaler.mean.size()) return Error{"classify: summary features do not match the model"};
    const Eigen::RowVectorXd z = ((*f - m.scaler.mean).array() / m.scaler.std.array()).matrix().transpose();
    Verdict v;
    for (std::size_t li = 0; li < m.labels.size(); ++li)
      v.score.push_back(-(z - m.centroids.row(static_cast<Eigen::Index>(li))).squaredNorm() / static_cast<double>(z.size()));
    const auto best = static_cast<std::size_t>(std::max_element(v.score.begin(), v.score.end()) - v.score.begin());
    v.label = m.labels[best];
    double second = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < v.score.size(); ++i)
      if (i != best) second = std::max(second, v.score[i]);
    v.margin = v.score.size() > 1 ? v.score[best] - second : 0;
    return v;
  }
  // No copy unless the model normalises or decimates (classify time unchanged for the seed's models).
  Sequence prepared;
  if (m.options.normalise || m.options.decimate > 1) prepared = prepare(x_in, m.feature_names, m.options);
  const Sequence& x = m.options.normalise || m.options.decimate > 1 ? prepared : x_in;
  if (x.cols() != m.scaler.mean.size())
    return Error{"classify: the sequence has " + std::to_string(x.cols()) + " features, the model expects " +
                 std::to_string(m.scaler.mean.size())};
  if (Status st = check_finite(x, "classify", m.feature_names); !st) return Error{st.error()};
  const Sequence z = m.scaler.apply(x);
  Verdict v;
  const double T = static_cast<double>(z.rows());
  for (std::size_t li = 0; li < m.labels.size(); ++li) {
    double s = 0;
    switch (m.method) {
      case Method::kDiscreteHmm: {
        auto ll = m.dhmm[li].log_likelihood(m.codebook.quantise(z));
        if (!ll) return Error{"classify: " + ll.error()};
        s = *ll / T;
        break;
      }
      case Method::kGaussianHmm: {
        auto ll = m.ghmm[li].log_likelihood(z);
        if (!ll) return Error{"classify: " + ll.error()};
        s = *ll / T;
        break;
      }
      case Method::kDtw: {
        const Sequence r = resample(z, m.options.dtw_length);
        // Nearest template of the label (1-NN): a class whose members vary
        // (novices) is not penalised for its spread.
        double best = std::numeric_limits<double>::infinity();
        for (const auto& t : m.templates[li]) best = std::min(best, dtw_distance(r, t, m.options.dtw_window));
        s = -best;
        break;
      }
      case Method::kSkill:
      case Method::kSkillLda:
      case Method::kTime:
      case Method::kTimePath: break;  // handled above
    }
    v.score.push_back(s);
  }
  std::vector<std::size_t> idx(v.score.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return v.score[a] > v.score[b]; });
  v.label = m.labels[idx[0]];
  v.margin = idx.size() > 1 ? v.score[idx[0]] - v.score[idx[1]] : 0;
  return v;
}

Result<CvResult> cross_validate_subjects(const std::vector<Trial>& trials, const std::vector<std::string>& names,
                                         const AssessOptions& opt) {
  return cross_validate(trials, names, opt, CvMode::kSubject);
}

Result<CvResult> cross_validate(const std::vector<Trial>& trials_in, const std::vector<std::string>& names,
                                const AssessOptions& opt, CvMode mode) {
  const std::vector<Trial>& trials = trials_in;
  // The label cross-validated: the skill, or the person (identification).
  auto label = [&](const Trial& t) -> const std::string& { return mode == CvMode::kIdentity ? t.subject : t.label; };
  std::set<std::string> subjects, labels;
  std::set<int> trial_numbers;
  for (const auto& t : trials) {
    subjects.insert(t.subject);
    labels.insert(label(t));
    trial_numbers.insert(t.trial);
  }
  if (mode == CvMode::kSubject && subjects.size() < 3)
    return Error{"cross-validation: needs at least 3 subjects, got " + std::to_string(subjects.size())};
  if (mode != CvMode::kSubject && trial_numbers.size() < 2)
    return Error{"cross-validation by trial: needs at least 2 trial numbers per person, got " +
                 std::to_string(trial_numbers.size())};
  // Folds: one per person (kSubject) or per trial number (kTrial, kIdentity).
  std::vector<std::string> folds;
  if (mode == CvMode::kSubject) folds.assign(subjects.begin(), subjects.end());
  else
    for (int k : trial_numbers) folds.push_back(std::to_string(k));
  auto in_fold = [&](const Trial& t, const std::string& f) {
    return mode == CvMode::kSubject ? t.subject == f : std::to_string(t.trial) == f;
  };
  CvResult r;
  r.labels.assign(labels.begin(), labels.end());
  r.confusion.assign(r.labels.size(), std::vector<int>(r.labels.size(), 0));
  r.predicted.assign(trials.size(), "");
  const std::string fold_word = mode == CvMode::kSubject ? "person " : "trial ";
  for (const auto& s : folds) {
    std::vector<const Trial*> train;
    std::vector<std::string> train_label;
    std::set<std::string> train_labels;
    for (const auto& t : trials)
      if (!in_fold(t, s)) {
        train.push_back(&t);
        train_label.push_back(label(t));
        train_labels.insert(label(t));
      }
    for (const auto& t : trials)
      if (in_fold(t, s) && !train_labels.count(label(t))) {
        if (mode == CvMode::kIdentity)
          return Error{"cross-validation (identity): person '" + t.subject + "' has no other trial than number " + s +
                       " to train on: person identification needs every person's trials numbered alike, 2 or more each"};
        return Error{"cross-validation: label '" + t.label + "': leaving out " + fold_word + s +
                     " leaves no '" + t.label + "' trial to train on (" +
                     (mode == CvMode::kSubject ? "every label needs trials of at least 2 persons"
                                               : "every label needs trials numbered alike") + "); " +
                     t.source + " is one of its trials"};
      }
    auto m = train_impl(train, train_label, names, opt);
    if (!m) return Error{"cross-validation (leaving out " + fold_word + s + "): " + m.error()};
    for (std::size_t i = 0; i < trials.size(); ++i) {
      if (!in_fold(trials[i], s)) continue;
      auto v = classify(*m, trials[i].x, trials[i].rate_hz);
      if (!v) return Error{"cross-validation: " + trials[i].source + ": " + v.error()};
      r.predicted[i] = v->label;
      const auto ti = static_cast<std::size_t>(std::find(r.labels.begin(), r.labels.end(), label(trials[i])) - r.labels.begin());
      const auto pi = static_cast<std::size_t>(std::find(r.labels.begin(), r.labels.end(), v->label) - r.labels.begin());
      if (pi < r.labels.size()) ++r.confusion[ti][pi];
      ++r.n;
      if (v->label == label(trials[i])) ++r.correct;
    }
  }
  r.accuracy = r.n ? static_cast<double>(r.correct) / r.n : 0;
  wilson_interval(r.correct, r.n, r.ci_low, r.ci_high);
  return r;
}

namespace {
using nlohmann::json;
json mat(const Eigen::MatrixXd& m) {
  json a = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    a.push_back(row);
  }
  return a;
}
json vec(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
  return a;
}
bool to_mat(const json& j, Eigen::MatrixXd& m) {
  if (!j.is_array() || j.empty() || !j[0].is_array()) return false;
  m.resize(static_cast<Eigen::Index>(j.size()), static_cast<Eigen::Index>(j[0].size()));
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_array() || j[i].size() != j[0].size()) return false;
    for (std::size_t k = 0; k < j[i].size(); ++k) {
      if (!j[i][k].is_number()) return false;
      m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = j[i][k].get<double>();
    }
  }
  return true;
}
// A member of an object, or null when it is absent or `o` is no object:
// nlohmann's const operator[] is undefined for a missing key (it read past the
// map in the fuzz replay under valgrind, session 23).
const json& member(const json& o, const char* key) {
  static const json kNull;
  if (!o.is_object()) return kNull;
  const auto it = o.find(key);
  return it == o.end() ? kNull : *it;
}
bool to_vec(const json& j, Eigen::VectorXd& v) {
  if (!j.is_array() || j.empty()) return false;
  v.resize(static_cast<Eigen::Index>(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number()) return false;
    v(static_cast<Eigen::Index>(i)) = j[i].get<double>();
  }
  return true;
}
}  // namespace

std::string model_to_json(const SkillModel& m) {
  json j;
  j["format"] = "dentar-skill-model";
  j["version"] = 1;
  j["method"] = method_name(m.method);
  j["features"] = m.feature_names;
  j["labels"] = m.labels;
  j["options"] = {{"states", m.options.states}, {"symbols", m.options.symbols}, {"iterations", m.options.iterations},
                  {"floor", m.options.floor}, {"var_floor", m.options.var_floor}, {"dtw_length", m.options.dtw_length},
                  {"dtw_window", m.options.dtw_window}, {"seed", m.options.seed},
                  {"normalise", m.options.normalise}, {"decimate", m.options.decimate}};
  j["scaler"] = {{"mean", vec(m.scaler.mean)}, {"std", vec(m.scaler.std)}};
  if (m.method == Method::kDiscreteHmm) j["codebook"] = mat(m.codebook.centroids);
  json models = json::array();
  for (std::size_t i = 0; i < m.labels.size(); ++i) {
    json mj;
    if (m.method == Method::kDiscreteHmm)
      mj = {{"pi", vec(m.dhmm[i].pi)}, {"A", mat(m.dhmm[i].A)}, {"B", mat(m.dhmm[i].B)}, {"floor", m.dhmm[i].floor}};
    else if (m.method == Method::kGaussianHmm)
      mj = {{"pi", vec(m.ghmm[i].pi)}, {"A", mat(m.ghmm[i].A)}, {"mean", mat(m.ghmm[i].mean)}, {"var", mat(m.ghmm[i].var)}};
    else if (is_summary(m.method))
      mj = {{"centroid", vec(m.centroids.row(static_cast<Eigen::Index>(i)).transpose())}};
    else {
      mj["templates"] = json::array();
      for (const auto& t : m.templates[i]) mj["templates"].push_back(mat(t));
    }
    models.push_back(mj);
  }
  j["models"] = models;
  return j.dump();
}

Result<SkillModel> model_from_json(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  auto bad = [&](const std::string& f) { return Error{name + ": field '" + f + "' missing or malformed"}; };
  if (j.is_discarded() || !j.is_object()) return Error{name + ": not a JSON skill model"};
  if (j.value("format", "") != "dentar-skill-model") return Error{name + ": field 'format' must be \"dentar-skill-model\""};
  SkillModel m;
  if (!j.contains("method") || !j["method"].is_string()) return bad("method");
  auto meth = parse_method(j["method"].get<std::string>());
  if (!meth) return Error{name + ": field 'method': " + meth.error()};
  m.method = *meth;
  m.options.method = m.method;
  try {
    m.feature_names = j.at("features").get<std::vector<std::string>>();
    m.labels = j.at("labels").get<std::vector<std::string>>();
    const json& o = j.at("options");
    m.options.states = o.at("states").get<int>();
    m.options.symbols = o.at("symbols").get<int>();
    m.options.dtw_length = o.at("dtw_length").get<int>();
    m.options.dtw_window = o.at("dtw_window").get<int>();
    m.options.normalise = o.value("normalise", false);
    m.options.decimate = o.value("decimate", 1);
    if (m.options.decimate < 1 || m.options.decimate > 1000) return bad("options.decimate");
  } catch (const json::exception& e) {
    return Error{name + ": " + e.what()};
  }
  if (!to_vec(member(member(j, "scaler"), "mean"), m.scaler.mean) ||
      !to_vec(member(member(j, "scaler"), "std"), m.scaler.std) ||
      m.scaler.mean.size() != m.scaler.std.size() || (m.scaler.std.array() <= 0).any())
    return bad("scaler");
  if (m.method == Method::kDiscreteHmm) {
    Eigen::MatrixXd c;
    if (!to_mat(member(j, "codebook"), c) || c.cols() != m.scaler.mean.size()) return bad("codebook");
    m.codebook.centroids = c;
  }
  if (!j.contains("models") || !j["models"].is_array() || j["models"].size() != m.labels.size()) return bad("models");
  for (std::size_t i = 0; i < m.labels.size(); ++i) {
    const json& mj = j["models"][i];  // an array of labels.size(), checked above
    const std::string f = "models[" + std::to_string(i) + "]";
    if (m.method == Method::kDiscreteHmm) {
      DiscreteHmm h;
      Eigen::MatrixXd A, B;
      if (!to_vec(member(mj, "pi"), h.pi) || !to_mat(member(mj, "A"), A) || !to_mat(member(mj, "B"), B)) return bad(f);
      h.A = A;
      h.B = B;
      const json& fl = member(mj, "floor");
      if (!fl.is_null() && !fl.is_number()) return bad(f + ".floor");
      h.floor = fl.is_null() ? 1e-4 : fl.get<double>();
      if (std::string why = h.validate(); !why.empty()) return Error{name + ": " + f + ": " + why};
      if (h.symbols() != m.codebook.centroids.rows()) return Error{name + ": " + f + ": B has the wrong number of symbols"};
      m.dhmm.push_back(h);
    } else if (is_summary(m.method)) {
      Eigen::VectorXd c;
      if (!to_vec(member(mj, "centroid"), c) || c.size() != m.scaler.mean.size()) return bad(f + ".centroid");
      if (m.centroids.rows() == 0) m.centroids.resize(static_cast<Eigen::Index>(m.labels.size()), c.size());
      m.centroids.row(static_cast<Eigen::Index>(i)) = c.transpose();
    } else if (m.method == Method::kGaussianHmm) {
      GaussianHmm g;
      Eigen::MatrixXd A, mu, var;
      if (!to_vec(member(mj, "pi"), g.pi) || !to_mat(member(mj, "A"), A) || !to_mat(member(mj, "mean"), mu) ||
          !to_mat(member(mj, "var"), var)) return bad(f);
      g.A = A;
      g.mean = mu;
      g.var = var;
      if (std::string why = g.validate(); !why.empty()) return Error{name + ": " + f + ": " + why};
      if (g.dims() != m.scaler.mean.size()) return Error{name + ": " + f + ": wrong feature count"};
      m.ghmm.push_back(g);
    } else {
      std::vector<Sequence> tpl;
      const json& tj_all = member(mj, "templates");
      if (!tj_all.is_array() || tj_all.empty()) return bad(f + ".templates");
      for (const auto& tj : tj_all) {
        Eigen::MatrixXd t;
        if (!to_mat(tj, t) || t.cols() != m.scaler.mean.size()) return bad(f + ".templates");
        tpl.push_back(t);
      }
      m.templates.push_back(tpl);
    }
  }
  return m;
}

}  // namespace dentar::training
