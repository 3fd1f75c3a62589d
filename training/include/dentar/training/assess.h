// Skill assessment: one model per skill label (discrete HMM on k-means
// symbols, Gaussian HMM, or DTW templates), trained on z-scaled features;
// a sequence gets the label whose model scores it best. Leave-one-subject-out
// cross-validation with a Wilson interval and the confusion matrix. Models
// are saved as JSON (docs/formats.md, "Skill model").
#pragma once

#include <string>
#include <vector>

#include "dentar/training/models.h"

namespace dentar::training {

// kSkill, kTime, kTimePath: nearest class centroid (z-scaled, diagonal
// pooled variance) on per-trial summary features (skill_features.h): the
// skill features, task time alone, task time and path length (baselines).
// kSkillLda: the skill features, nearest class centroid in units of the
// pooled within-class SD (diagonal LDA) instead of the total SD.
enum class Method { kDiscreteHmm, kGaussianHmm, kDtw, kSkill, kSkillLda, kTime, kTimePath };
std::string method_name(Method m);
Result<Method> parse_method(const std::string& s);

struct Trial {
  std::string subject, label, source;
  int trial = 0;
  Sequence x;  // T x D features
  double rate_hz = 100;  // frames per second of x (summary features need it)
};

struct AssessOptions {
  Method method = Method::kDiscreteHmm;
  int states = 13;         // hidden states (the seed: one per stage)
  int symbols = 13;        // k-means codebook size (discrete HMM)
  int iterations = 30;     // Baum-Welch iterations at most
  double floor = 1e-4;     // emission floor (discrete HMM)
  double var_floor = 1e-2; // variance floor in z units (Gaussian HMM)
  int dtw_length = 200;    // DTW: sequences resampled to this many rows
  int dtw_window = 20;     // Sakoe-Chiba band (rows)
  std::uint64_t seed = 1;
  // Sequence methods: per-trial normalisation (skill_features.h,
  // normalise_trial) before the z-scaling: removes a person's posture,
  // orientation habit, force level and speed.
  bool normalise = false;
  int decimate = 1;  // sequence methods: keep every n-th frame (HMM time)
  std::string validate() const;
};

struct SkillModel {
  Method method = Method::kDiscreteHmm;
  AssessOptions options;
  std::vector<std::string> feature_names;
  std::vector<std::string> labels;  // sorted
  ZScaler scaler;
  KMeans codebook;                   // discrete HMM only
  std::vector<DiscreteHmm> dhmm;     // per label
  std::vector<GaussianHmm> ghmm;     // per label
  std::vector<std::vector<Sequence>> templates;  // DTW: per label, z-scaled and resampled
  Sequence centroids;                // summary methods: per label, in z units of `scaler`
};

Result<SkillModel> train_model(const std::vector<Trial>& trials, const std::vector<std::string>& feature_names,
                               const AssessOptions& opt);

struct Verdict {
  std::string label;
  std::vector<double> score;  // per model label: log-likelihood per step (HMMs) or minus the DTW distance to the label's nearest template
  double margin = 0;          // best minus second best score
};
// rate_hz: frames per second of x (summary methods; the sequence methods ignore it).
Result<Verdict> classify(const SkillModel& m, const Sequence& x, double rate_hz = 100);

struct CvResult {
  int n = 0, correct = 0;
  double accuracy = 0, ci_low = 0, ci_high = 0;  // Wilson 95 % interval
  std::vector<std::string> labels;
  std::vector<std::vector<int>> confusion;  // [true][predicted]
  std::vector<std::string> predicted;       // per trial, in input order
};
// kSubject: leave one person out (what a trainer meeting a new student
// faces). kTrial: leave the k-th trial of every person out, k = 1.. (the
// person stays in training: this can measure who is operating, not how
// well). kIdentity: as kTrial, but the label is the person (the leakage
// check: how well the same features identify the person).
// A fold whose test trials have a label absent from its training trials is
// an error naming the label and the person (or trial number).
enum class CvMode { kSubject, kTrial, kIdentity };
Result<CvResult> cross_validate(const std::vector<Trial>& trials, const std::vector<std::string>& feature_names,
                                const AssessOptions& opt, CvMode mode);
Result<CvResult> cross_validate_subjects(const std::vector<Trial>& trials,
                                         const std::vector<std::string>& feature_names, const AssessOptions& opt);
// Wilson score interval for k successes in n trials (z = 1.96).
void wilson_interval(int k, int n, double& lo, double& hi);

std::string model_to_json(const SkillModel& m);
Result<SkillModel> model_from_json(const std::string& text, const std::string& name);

}  // namespace dentar::training
