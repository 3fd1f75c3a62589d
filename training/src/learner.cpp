#include "dentar/training/learner.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <random>
#include <sstream>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"

namespace dentar::training {

LearnerModel LearnerModel::novice() { return LearnerModel{}; }

LearnerModel LearnerModel::skilled() {
  LearnerModel m;
  m.name = "skilled";
  m.lag_s = 0.2;
  m.noise_mm = 0.15;
  m.feedback_tau_s = 0.3;
  m.prior_blur_s = 0.4;
  m.prior_offset_mm = 0.4;
  return m;
}

std::string LearnerModel::validate() const {
  std::ostringstream os;
  auto bad = [](double v, double lo, double hi) { return !std::isfinite(v) || v < lo || v > hi; };
  if (bad(lag_s, 0, 2))
    os << "learner lag_s = " << lag_s << " must be in [0, 2]";
  else if (bad(noise_mm, 0, 10))
    os << "learner noise_mm = " << noise_mm << " must be in [0, 10]";
  else if (bad(noise_tau_s, 1e-3, 10))
    os << "learner noise_tau_s = " << noise_tau_s << " must be in [0.001, 10]";
  else if (bad(grip_N_per_m, 1, 5000))
    os << "learner grip_N_per_m = " << grip_N_per_m << " must be in [1, 5000]";
  else if (bad(damping_ratio, 0.01, 5))
    os << "learner damping_ratio = " << damping_ratio << " must be in [0.01, 5]";
  else if (bad(feedback_tau_s, 0.01, 10))
    os << "learner feedback_tau_s = " << feedback_tau_s << " must be in [0.01, 10]";
  else if (bad(feedback_max_mm, 0, 50))
    os << "learner feedback_max_mm = " << feedback_max_mm << " must be in [0, 50]";
  else if (bad(prior_blur_s, 0, 30))
    os << "learner prior_blur_s = " << prior_blur_s << " must be in [0, 30]";
  else if (bad(prior_offset_mm, 0, 20))
    os << "learner prior_offset_mm = " << prior_offset_mm << " must be in [0, 20]";
  else if (bad(prior_offset_tau_s, 1e-3, 60))
    os << "learner prior_offset_tau_s = " << prior_offset_tau_s << " must be in [0.001, 60]";
  else if (bad(bin_s, 0.005, 1))
    os << "learner bin_s = " << bin_s << " must be in [0.005, 1]";
  else if (bad(error_rate, 0, 1))
    os << "learner error_rate = " << error_rate << " must be in [0, 1]";
  else if (bad(error_half_mm, 1e-3, 100))
    os << "learner error_half_mm = " << error_half_mm << " must be in [0.001, 100]";
  else if (bad(use_rate, 0, 1))
    os << "learner use_rate = " << use_rate << " must be in [0, 1]";
  else if (bad(error_rate + use_rate, 0, 1))
    os << "learner error_rate + use_rate = " << error_rate + use_rate << " must be <= 1";
  else if (bad(force_credit, 0, 1))
    os << "learner force_credit = " << force_credit << " must be in [0, 1]";
  else if (bad(retention, 0, 1))
    os << "learner retention = " << retention << " must be in [0, 1]";
  return os.str();
}

StudentModel LearnerModel::student(std::uint64_t seed) const {
  StudentModel s;
  s.passive = false;
  s.lag_s = lag_s;
  s.noise_mm = noise_mm;
  s.noise_tau_s = noise_tau_s;
  s.grip_N_per_m = grip_N_per_m;
  s.damping_ratio = damping_ratio;
  s.seed = seed;
  return s;
}

LearnedPath LearnedPath::prior(const haptics::ExpertTrack& track, double seconds,
                               const LearnerModel& model, std::uint64_t seed) {
  LearnedPath p;
  p.bin_ = model.bin_s;
  const double end = std::min(seconds > 0 ? seconds : track.duration_s(), track.duration_s());
  const std::size_t n = static_cast<std::size_t>(std::floor(end / p.bin_)) + 2;
  std::vector<Eigen::Vector3d> x(n);
  for (std::size_t j = 0; j < n; ++j)
    x[j] = track.at(static_cast<double>(j) * p.bin_).T_tooth_tip.translation();
  // The blur: a Gaussian over lesson time, renormalised at the ends.
  p.prior_.assign(n, Eigen::Vector3d::Zero());
  const double sigma = model.prior_blur_s / p.bin_;
  const long half = sigma > 0 ? static_cast<long>(std::ceil(3 * sigma)) : 0;
  for (std::size_t j = 0; j < n; ++j) {
    Eigen::Vector3d acc = Eigen::Vector3d::Zero();
    double w = 0;
    for (long d = -half; d <= half; ++d) {
      const long i = static_cast<long>(j) + d;
      if (i < 0 || i >= static_cast<long>(n)) continue;
      const double wi = sigma > 0 ? std::exp(-0.5 * d * d / (sigma * sigma)) : 1.0;
      acc += wi * x[static_cast<std::size_t>(i)];
      w += wi;
    }
    p.prior_[j] = acc / w;
  }
  // The personal offset: an Ornstein-Uhlenbeck process over lesson time, per axis (seeded).
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 17);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double a = std::exp(-p.bin_ / model.prior_offset_tau_s), sd = model.prior_offset_mm * 1e-3;
  Eigen::Vector3d o(sd * n01(rng), sd * n01(rng), sd * n01(rng));
  for (std::size_t j = 0; j < n; ++j) {
    if (j > 0)
      for (int k = 0; k < 3; ++k) o[k] = a * o[k] + sd * std::sqrt(1 - a * a) * n01(rng);
    p.prior_[j] += o;
  }
  p.m_ = p.prior_;
  return p;
}

Eigen::Vector3d LearnedPath::at(double tau_s) const noexcept {
  if (m_.empty()) return Eigen::Vector3d::Zero();
  const double x = std::isfinite(tau_s) ? std::max(0.0, tau_s / bin_) : 0.0;
  const std::size_t j = static_cast<std::size_t>(x);
  if (j + 1 >= m_.size()) return m_.back();
  const double f = x - static_cast<double>(j);
  return (1 - f) * m_[j] + f * m_[j + 1];
}

void LearnedPath::learn(const std::vector<LearnerSample>& trace, const LearnerModel& model) {
  const std::size_t n = m_.size();
  if (n == 0) return;
  std::vector<Eigen::Vector3d> S(n, Eigen::Vector3d::Zero()), H(n, Eigen::Vector3d::Zero());
  std::vector<double> W(n, 0.0);
  const double end = static_cast<double>(n - 1) * bin_;
  const double credit = model.force_credit / model.grip_N_per_m;
  for (const LearnerSample& t : trace) {
    if (!(t.expert_time_s >= 0 && t.expert_time_s <= end)) continue;
    // The error credited to one's own plan (learner.h).
    const Eigen::Vector3d s = (t.expert_tip - t.hand_tip) + t.feedback + credit * t.force_N;
    if (!s.allFinite() || !t.hand_tip.allFinite()) continue;
    const double x = t.expert_time_s / bin_;
    const std::size_t j = std::min(static_cast<std::size_t>(x), n - 1);
    const double f = j + 1 < n ? x - static_cast<double>(j) : 0.0;
    S[j] += (1 - f) * s;
    H[j] += (1 - f) * t.hand_tip;
    W[j] += 1 - f;
    if (j + 1 < n && f > 0) {
      S[j + 1] += f * s;
      H[j + 1] += f * t.hand_tip;
      W[j + 1] += f;
    }
  }
  std::vector<Eigen::Vector3d> s(n, Eigen::Vector3d::Zero());
  for (std::size_t j = 0; j < n; ++j)
    if (W[j] > 0) s[j] = S[j] / W[j];
  // Local generalisation: [1 2 1] / 4 over neighbouring nodes that had samples.
  std::vector<Eigen::Vector3d> sm(n, Eigen::Vector3d::Zero());
  for (std::size_t j = 0; j < n; ++j) {
    if (W[j] <= 0) continue;
    Eigen::Vector3d acc = 2 * s[j];
    double w = 2;
    if (j > 0 && W[j - 1] > 0) acc += s[j - 1], w += 1;
    if (j + 1 < n && W[j + 1] > 0) acc += s[j + 1], w += 1;
    sm[j] = acc / w;
  }
  const double half = model.error_half_mm * 1e-3;
  for (std::size_t j = 0; j < n; ++j) {
    if (W[j] > 0) {
      const double e = sm[j].norm();
      m_[j] +=
          model.error_rate * half / (half + e) * sm[j] + model.use_rate * (H[j] / W[j] - m_[j]);
    }
    m_[j] = prior_[j] + model.retention * (m_[j] - prior_[j]);
  }
}

double LearnedPath::mean_distance_to(const haptics::ExpertTrack& track) const {
  if (m_.empty()) return 0;
  double acc = 0;
  for (std::size_t j = 0; j < m_.size(); ++j)
    acc += (m_[j] - track.at(static_cast<double>(j) * bin_).T_tooth_tip.translation()).norm();
  return acc / static_cast<double>(m_.size());
}

const char* condition_name(GuidanceCondition c) {
  switch (c) {
    case GuidanceCondition::kNone:
      return "none";
    case GuidanceCondition::kFixed:
      return "fixed";
    case GuidanceCondition::kAsNeeded:
      return "as_needed";
    case GuidanceCondition::kFading:
      return "fading";
    case GuidanceCondition::kAcrossPath:
      return "across_path";
    case GuidanceCondition::kAmplify:
      return "amplify";
    case GuidanceCondition::kPlan:
      return "plan";
  }
  return "?";
}

Result<GuidanceCondition> parse_condition(const std::string& s) {
  for (GuidanceCondition c : fixed_conditions())
    if (s == condition_name(c)) return c;
  if (s == "plan") return GuidanceCondition::kPlan;
  return Error{"condition '" + s +
               "' is not one of none, fixed, as_needed, fading, across_path, amplify, plan"};
}

const std::vector<GuidanceCondition>& fixed_conditions() {
  static const std::vector<GuidanceCondition> v = {
      GuidanceCondition::kNone,   GuidanceCondition::kFixed,      GuidanceCondition::kAsNeeded,
      GuidanceCondition::kFading, GuidanceCondition::kAcrossPath, GuidanceCondition::kAmplify};
  return v;
}

std::string LearningOptions::validate() const {
  if (repetitions < 1 || repetitions > 1000)
    return "repetitions = " + std::to_string(repetitions) + " must be in [1, 1000]";
  if (!std::isfinite(seconds) || seconds < 1) return "seconds must be >= 1";
  if (!(fade > 0 && fade <= 1)) return "fade must be in (0, 1]";
  if (!(amplify > 0 && amplify <= 1)) return "amplify must be in (0, 1]";
  return plan.validate();
}

Result<LearningCurve> run_learning_curve(const Lesson& lesson, const LearnerModel& model,
                                         GuidanceCondition c, std::uint64_t seed,
                                         const LearningOptions& opt) {
  if (std::string v = model.validate(); !v.empty()) return Error{v};
  if (std::string v = opt.validate(); !v.empty()) return Error{v};
  const std::clock_t c0 = std::clock();
  // The expert's path, as run_lesson reads it (the learner's prior is built from it).
  const std::string rp = lesson.recording_path();
  auto log = haptics::read_session_log(rp);
  if (!log) return Error{"the lesson's recording: " + log.error()};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{rp + ": " + setup.error()};
  auto track = haptics::ExpertTrack::from_records(log->records, setup->engine.T_tooth_dev,
                                                  setup->engine.T_sty_tip, rp);
  if (!track) return Error{track.error()};
  const double seconds = std::min(opt.seconds, track->duration_s());
  LearnedPath memory = LearnedPath::prior(*track, seconds, model, seed);

  LearningCurve out;
  out.learner = model.name;
  out.condition = condition_name(c);
  out.seed = seed;
  std::vector<LearnerSample> trace;
  // The wander's seed depends on the learner's seed and the run's place in the schedule,
  // not on the condition: the conditions share their noise (common random numbers).
  auto run = [&](int mode, const haptics::GuidanceParams& g, bool recall, std::uint64_t slot) {
    Lesson l = lesson;
    l.params.guidance = g;
    LessonRunOptions o;
    o.mode = mode;
    o.device = opt.device;
    o.student = model.student(seed * 1000003ull + slot);
    o.seconds = seconds;
    o.pauses = false;
    o.learner.memory = &memory;
    o.learner.feedback_tau_s = model.feedback_tau_s;
    o.learner.feedback_max_m = model.feedback_max_mm * 1e-3;
    o.learner.recall = recall;
    o.learner.trace = recall ? nullptr : &trace;
    return run_lesson(l, o);
  };
  const haptics::GuidanceParams base = lesson.params.guidance;
  auto before = run(1, base, true, 999);
  if (!before) return Error{before.error()};
  out.before_mean_m = before->follow_mean_m;
  out.before_p95_m = before->follow_p95_m;

  std::vector<PastSession> history;
  const std::string skill = model.name == "skilled" ? "expert" : "novice";
  for (int rep = 0; rep < opt.repetitions; ++rep) {
    RepetitionResult rr;
    haptics::GuidanceParams g = base;
    int mode = 2;
    switch (c) {
      case GuidanceCondition::kNone:
        mode = 1;
        break;
      case GuidanceCondition::kFixed:
        break;
      case GuidanceCondition::kAsNeeded:
        g.as_needed = true;
        break;
      case GuidanceCondition::kFading:
        g.fade = opt.fade;
        g.repetition = rep;
        break;
      case GuidanceCondition::kAcrossPath:
        g.across_path_only = true;
        break;
      case GuidanceCondition::kAmplify:
        g.amplify = opt.amplify;
        break;
      case GuidanceCondition::kPlan: {
        const LessonPlan p = plan_next(history, opt.plan);
        mode = p.mode;
        g = p.guidance;
        rr.rule = p.rule;
        break;
      }
    }
    auto r = run(mode, g, false, static_cast<std::uint64_t>(rep));
    if (!r) return Error{r.error()};
    memory.learn(trace, model);
    rr.mode = r->mode_run;
    rr.guidance = r->guidance;
    rr.train_mean_m = r->follow_mean_m;
    rr.train_p95_m = r->follow_p95_m;
    rr.mean_force_N = r->mean_force_N;
    rr.memory_m = memory.mean_distance_to(*track);
    if (opt.probe_each) {
      auto pr = run(1, base, true, 500 + static_cast<std::uint64_t>(rep));
      if (!pr) return Error{pr.error()};
      rr.probe_mean_m = pr->follow_mean_m;
      rr.probe_p95_m = pr->follow_p95_m;
    }
    PastSession ps;
    ps.path = "repetition " + std::to_string(rep + 1);
    ps.mode = rr.mode;
    ps.guidance = rr.guidance;
    ps.has_follow = true;
    ps.follow_from = "run.json";
    ps.follow_mean_m = rr.train_mean_m;
    ps.follow_p95_m = rr.train_p95_m;
    ps.skill = skill;
    history.push_back(ps);
    out.reps.push_back(rr);
  }
  auto after = run(1, base, true, 1000);
  if (!after) return Error{after.error()};
  out.retention_mean_m = after->follow_mean_m;
  out.retention_p95_m = after->follow_p95_m;
  out.cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  return out;
}

}  // namespace dentar::training
