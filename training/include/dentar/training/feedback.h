// Objective tutoring feedback per procedure step: the student's force,
// position, orientation and time against the experts' mean and SD, in the
// seed's style. The wording is generated from the statistics (never canned
// per exercise); rules in docs/formats.md ("Tutoring feedback").
#pragma once

#include <string>
#include <vector>

#include "dentar/training/session.h"

namespace dentar::training {

// Expert statistics per step (mean and SD over expert sessions of the
// per-session step means).
struct StepReference {
  std::string name;
  int sessions = 0;
  Eigen::Vector3d force_mean = Eigen::Vector3d::Zero(), force_sd = Eigen::Vector3d::Zero();  // N, tooth axes
  Eigen::Vector3d tip_mean_mm = Eigen::Vector3d::Zero(), tip_sd_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_mean = Eigen::Vector3d::UnitZ();
  double axis_sd_deg = 0;
  double drilling_mean_s = 0, drilling_sd_s = 0;
  // Mirror use, over the experts whose views were measured (view_sessions;
  // 0: no expert views, no mirror advice): % of the step's drilling frames
  // with the site seen in the mirror (classes mirror + both), and seen
  // neither way (none).
  int view_sessions = 0;
  double mirror_pct_mean = 0, mirror_pct_sd = 0, no_sight_pct_mean = 0, no_sight_pct_sd = 0;
};
struct ExpertReference {
  std::string exercise;
  int sessions = 0;  // expert sessions behind the whole-session statistics
  std::vector<StepReference> steps;
  // Whole-session process metrics: mean and SD.
  double duration_mean_s = 0, duration_sd_s = 0, path_mean_mm = 0, path_sd_mm = 0;
  double drilling_mean_s = 0, drilling_sd_s = 0, excessive_mean_s = 0, excessive_sd_s = 0;
};
ExpertReference build_reference(const std::string& exercise, const std::vector<ProcessMetrics>& experts);
std::string reference_to_json(const ExpertReference& r);
Result<ExpertReference> reference_from_json(const std::string& text, const std::string& name);

struct FeedbackRules {
  double min_frames = 10;       // a step needs this many drilling frames in contact to be judged
  int min_ref_sessions = 3;     // an expert mean and SD need this many expert sessions to be used
  double min_force_N = 0.05;    // a force below this is "almost none": no multiplier is given for it
  double band_sd = 1.0;         // "well done" within this many SDs
  double min_sd_N = 0.05;       // SD floor (N) so a very consistent expert set is not over-strict
  double max_multiplier = 3.0;  // never ask for more than this factor
  double off_axis_ratio = 0.35; // off-axis force above this fraction of the main force is "large"
  double position_mm = 0.5;     // position advice only beyond this distance and 2 SD
  double angle_deg = 10.0;      // orientation advice only beyond this angle and 2 SD
  // Mirror use (where the student's and the experts' views were measured):
  double min_view_frames = 10;    // drilling frames with the site classified, to judge a step
  double mirror_step_pct = 50;    // experts seeing the site in the mirror this often: an indirect-vision step
  double min_sd_pct = 5;          // SD floor (percentage points)
  double no_sight_pct = 20;       // working without sight of the site above this (and 2 SD) is cautioned
};

struct FeedbackMessage {
  int step = -1;  // -1: whole session
  std::string step_name;
  std::string kind;  // "well_done", "instruct", "ask", "caution"
  std::string text;
  // Which rule spoke (docs/feedback.md): force_low, force_none, force_opposite,
  // force_high, force_ok, off_axis, position, angle, drilling_time, no_contact,
  // mirror_use, mirror_ok, no_sight, excessive_force, path.
  std::string rule;
  // Force rules: the tooth axis (0 x, 1 y, 2 z) and the direction (+1/-1)
  // the text names; axis -1 when the message names no force direction.
  int axis = -1;
  int sign = 0;
};

// excessive_force_N caps "press harder" advice: the recommended force never
// exceeds it (more force could damage the tooth).
std::vector<FeedbackMessage> tutoring_feedback(const ProcessMetrics& student, const ExpertReference& ref,
                                               double excessive_force_N, const FeedbackRules& rules = {});

// The documented rules every message set must keep (docs/feedback.md),
// checked against the statistics it was made from: multipliers finite and
// >= 1.1, no limit of 0 N, no negative number (directions carry the sign)
// and direction words that agree with the student's and the experts'
// forces, no two messages that contradict each other in a step, nothing
// said from too few samples, the seed's "ask" where the main force is
// right. Empty when all hold; else one line per broken rule.
std::vector<std::string> feedback_violations(const ProcessMetrics& student, const ExpertReference& ref,
                                             double excessive_force_N, const std::vector<FeedbackMessage>& messages,
                                             const FeedbackRules& rules = {});

// Names of the tooth axes as the feedback uses them ("minus Z (long axis, apical)").
std::string axis_direction_name(int axis, double sign);

}  // namespace dentar::training
