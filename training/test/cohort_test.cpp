// End to end on a generated cohort: sessions through the engine, decoding,
// automatic steps against the generator's labels, leave-one-subject-out
// cross-validation with every method, model save/load.
#include "dentar/training/cohort.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "dentar/training/assess.h"
#include "dentar/training/session.h"
#include "testutil.h"

namespace dentar::training {
namespace {

struct Cohort {
  Exercise ex;
  std::vector<CohortTrial> trials;
  std::vector<SessionTrack> tracks;
  std::vector<Trial> features;
};

const Cohort& cohort() {
  static Cohort c = [] {
    Cohort c;
    auto ex = load_builtin_exercise("molar_access_opening");
    EXPECT_TRUE(ex.ok()) << ex.error();
    c.ex = *ex;
    CohortOptions o;
    o.experts = 3;
    o.novices = 3;
    o.trials = 2;
    o.voxel_mm = 0.2;
    o.bur_samples = 500;
    // One folder per process: ctest runs these tests as parallel processes.
    const std::string dir = dentar::test::temp_dir("cohort").string();
    std::filesystem::remove_all(dir);
    auto t = generate_cohort(c.ex, o, dir);
    EXPECT_TRUE(t.ok()) << t.error();
    auto back = read_cohort(dir);
    EXPECT_TRUE(back.ok()) << back.error();
    c.trials = *back;
    for (const auto& tr : c.trials) {
      auto log = haptics::read_session_log(tr.session_path);
      EXPECT_TRUE(log.ok()) << log.error();
      auto s = decode_session(*log, tr.session_path);
      EXPECT_TRUE(s.ok()) << s.error();
      c.features.push_back({tr.subject, tr.label, tr.session_path, tr.trial, track_features(*s)});
      c.tracks.push_back(std::move(*s));
    }
    return c;
  }();
  return c;
}

TEST(Cohort, SessionsCutTheToothAndNovicesDifferFromExperts) {
  const Cohort& c = cohort();
  ASSERT_EQ(c.trials.size(), 12u);
  double e_path = 0, n_path = 0;
  for (std::size_t i = 0; i < c.trials.size(); ++i) {
    const auto steps = segment_steps(c.tracks[i], c.ex, nullptr, nullptr);
    const ProcessMetrics p = process_metrics(c.tracks[i], c.ex, steps);
    EXPECT_GT(p.drilling_s, 1.0);
    double removed = 0;
    for (const auto& s : p.steps) removed += s.removed_mm3;
    EXPECT_GT(removed, 1.0) << c.trials[i].session_path;
    (c.trials[i].label == "expert" ? e_path : n_path) += p.path_mm;
  }
  EXPECT_GT(n_path, 1.2 * e_path);  // novices: detours and tremor
}

TEST(Cohort, AutomaticStepsAgreeWithTheGeneratorsLabels) {
  const Cohort& c = cohort();
  double agree = 0, n = 0;
  int spans = 0, true_spans = 0;
  for (std::size_t i = 0; i < c.trials.size(); ++i) {
    const auto steps = segment_steps(c.tracks[i], c.ex, nullptr, nullptr);
    int last_truth = -1;
    for (std::size_t f = 0; f < steps.size(); ++f) {
      spans += f == 0 || steps[f] != steps[f - 1];
      const int truth = c.trials[i].true_step_at(c.tracks[i].t_s[f]);
      if (truth >= 0 && truth != last_truth) {
        ++true_spans;
        last_truth = truth;
      }
      if (truth < 0 || c.tracks[i].removed_total(f) <= 0) continue;  // judged where material is removed
      agree += steps[f] == truth;
      n += 1;
    }
  }
  ASSERT_GT(n, 100);
  std::cerr << "access opening: step agreement " << agree / n << ", " << spans << " spans for " << true_spans
            << " generated steps\n";
  // Frames cut at the border between two steps' parts can go to the nearer focus. With the
  // session 14 switch costs, held-out cohorts agree on 0.89-0.93 of cutting frames (0.60-0.66
  // before) and the steps no longer flicker: 31 spans for 32 steps where 4 / 40 gave 707
  // (docs/BENCHMARKS.md, "the steps' flicker").
  EXPECT_GT(agree / n, 0.8) << "agreement " << agree / n;
  EXPECT_LE(spans, true_spans + true_spans / 2) << "the steps flicker";
}

TEST(Cohort, LeaveOneSubjectOutSeparatesClearlyDifferentCohorts) {
  const Cohort& c = cohort();
  for (Method m : {Method::kDiscreteHmm, Method::kGaussianHmm, Method::kDtw}) {
    AssessOptions o;
    o.method = m;
    o.states = m == Method::kDiscreteHmm ? 13 : 5;
    o.iterations = 15;
    auto r = cross_validate_subjects(c.features, track_feature_names(), o);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->n, 12);
    std::cerr << method_name(m) << ": leave-one-subject-out " << r->correct << " of " << r->n << "\n";
    // 12 trials of 6 subjects at full separation. DTW (1-NN on resampled
    // sequences) is the weakest, as in the literature (70-85 %).
    // Generator v4 measured HMM 12, GHMM 11, DTW 7 of 12: with 3 subjects a
    // class, a left-out novice has 4 novice templates against 6 expert ones,
    // and all DTW errors are novices nearest an expert; on 10 subjects (20
    // trials) DTW reaches 75-85 % (docs/BENCHMARKS.md). It must stay above chance.
    EXPECT_GE(r->accuracy, m == Method::kDtw ? 0.5 : 0.75) << method_name(m);
    EXPECT_LE(r->ci_low, r->accuracy);
    EXPECT_GE(r->ci_high, r->accuracy);
    int total = 0;
    for (const auto& row : r->confusion)
      for (int v : row) total += v;
    EXPECT_EQ(total, 12);
  }
}

TEST(Cohort, ModelRoundTripsThroughJson) {
  const Cohort& c = cohort();
  for (Method m : {Method::kDiscreteHmm, Method::kGaussianHmm, Method::kDtw}) {
    AssessOptions o;
    o.method = m;
    o.states = 4;
    o.iterations = 5;
    auto model = train_model(c.features, track_feature_names(), o);
    ASSERT_TRUE(model.ok()) << model.error();
    auto back = model_from_json(model_to_json(*model), "model.json");
    ASSERT_TRUE(back.ok()) << back.error();
    auto v1 = classify(*model, c.features[0].x);
    auto v2 = classify(*back, c.features[0].x);
    ASSERT_TRUE(v1.ok() && v2.ok());
    EXPECT_EQ(v1->label, v2->label);
    EXPECT_NEAR(v1->score[0], v2->score[0], 1e-6 * std::abs(v1->score[0]) + 1e-9);
    // A class model missing a member, or not an object, is an error naming it (session 23: the
    // loader read past the JSON map for a missing member, found by the fuzz replay under valgrind).
    const char* key = m == Method::kDtw ? "templates" : "pi";
    auto j = nlohmann::json::parse(model_to_json(*model));
    j["models"][0].erase(key);
    auto missing = model_from_json(j.dump(), "m.json");
    ASSERT_FALSE(missing.ok()) << key;
    EXPECT_NE(missing.error().find("m.json: field 'models[0]"), std::string::npos) << missing.error();
    j["models"][0] = 7;
    auto not_object = model_from_json(j.dump(), "m.json");
    ASSERT_FALSE(not_object.ok());
    EXPECT_NE(not_object.error().find("m.json: field 'models[0]"), std::string::npos) << not_object.error();
  }
  auto bad = model_from_json(R"({"format":"dentar-skill-model","method":"svm"})", "m.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("m.json: field 'method'"), std::string::npos) << bad.error();
}

TEST(Assess, WilsonIntervalMatchesHandComputation) {
  double lo, hi;
  wilson_interval(10, 10, lo, hi);  // 10/10: [0.722, 1]
  EXPECT_NEAR(lo, 0.7225, 1e-3);
  EXPECT_NEAR(hi, 1.0, 1e-12);
  wilson_interval(5, 10, lo, hi);  // [0.237, 0.763]
  EXPECT_NEAR(lo, 0.2366, 1e-3);
  EXPECT_NEAR(hi, 0.7634, 1e-3);
}

}  // namespace
}  // namespace dentar::training

namespace dentar::training {
namespace {

// The 13-step incisor preparation: steps approach from labial (-y) or
// incisal (+z), several share a region; the Viterbi order prior separates them.
TEST(Cohort, AutomaticStepsOnTheThirteenStepIncisorPreparation) {
  auto ex = load_builtin_exercise("incisor_partial_crown");
  ASSERT_TRUE(ex.ok()) << ex.error();
  CohortOptions o;
  o.experts = 1;
  o.novices = 1;
  o.trials = 1;
  o.voxel_mm = 0.2;
  o.bur_samples = 500;
  o.seed = 5;
  const std::string dir = dentar::test::temp_dir("incisor_cohort").string();
  std::filesystem::remove_all(dir);
  auto t = generate_cohort(*ex, o, dir);
  ASSERT_TRUE(t.ok()) << t.error();
  // One expert and one novice (o.experts, o.novices), each checked.
  ASSERT_EQ(t->size(), 2u);
  int experts = 0, novices = 0;
  for (const auto& tr : *t) {
    auto log = haptics::read_session_log(tr.session_path);
    ASSERT_TRUE(log.ok());
    auto s = decode_session(*log, tr.session_path);
    ASSERT_TRUE(s.ok());
    const auto steps = segment_steps(*s, *ex, nullptr, nullptr);
    double agree = 0, n = 0;
    for (std::size_t f = 0; f < steps.size(); ++f) {
      const int truth = tr.true_step_at(s->t_s[f]);
      if (truth < 0 || s->removed_total(f) <= 0) continue;
      agree += steps[f] == truth;
      n += 1;
    }
    // Spans: runs of one step. The truth's own (the generated hand's step changes, over the
    // frames it labels) bound the segmentation's: more is flicker.
    int spans = 0, true_spans = 0, last_truth = -2;
    for (std::size_t f = 0; f < steps.size(); ++f) {
      spans += f == 0 || steps[f] != steps[f - 1];
      const int truth = tr.true_step_at(s->t_s[f]);
      if (truth < 0) continue;
      true_spans += truth != last_truth;
      last_truth = truth;
    }
    std::cerr << tr.label << " incisor step agreement " << agree / n << " over " << n << " frames, " << spans
              << " spans for 13 steps (the truth " << true_spans << ")\n";
    ASSERT_GT(n, 50);
    ASSERT_TRUE(tr.label == "expert" || tr.label == "novice") << tr.label;
    (tr.label == "expert" ? experts : novices) += 1;
    // Generator v4 with the 4 / 40 switch costs: 67 % expert, 58 % novice, ~200
    // spans for 13 steps. The session 14 costs: 0.89-0.96 over held-out cohorts,
    // experts 0.95-1.0 with 13 spans (13 steps, chance 8 %; docs/BENCHMARKS.md).
    EXPECT_GT(agree / n, tr.label == "expert" ? 0.85 : 0.6);
    // Session 23: the flicker bound for both (it was the expert's alone; session 23's run: expert
    // 13 spans, novice 11).
    EXPECT_GE(true_spans, 1);
    EXPECT_LE(spans, true_spans + 3) << tr.label << ": the steps flicker";
  }
  EXPECT_EQ(experts, 1);
  EXPECT_EQ(novices, 1);
}

}  // namespace
}  // namespace dentar::training
