#include "dentar/training/feedback.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

namespace dentar::training {
namespace {

std::string num(double v, int prec = 1) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(prec);
  os << v;
  return os.str();
}

void mean_sd(const std::vector<double>& v, double& m, double& sd) {
  m = sd = 0;
  if (v.empty()) return;
  for (double x : v) m += x;
  m /= static_cast<double>(v.size());
  if (v.size() > 1) {
    for (double x : v) sd += (x - m) * (x - m);
    sd = std::sqrt(sd / static_cast<double>(v.size() - 1));
  }
}

// Tooth-frame directions: x mesio-distal (mesial -x), y bucco-lingual (buccal
// -y), z long axis (occlusal/incisal +z).
const char* direction_word(int axis, double sign) {
  static const char* w[3][2] = {{"mesial", "distal"}, {"buccal", "lingual"}, {"apical", "occlusal"}};
  return w[axis][sign > 0 ? 1 : 0];
}

}  // namespace

std::string axis_direction_name(int axis, double sign) {
  static const char* ax[3] = {"X", "Y", "Z"};
  return std::string(sign < 0 ? "minus " : "plus ") + ax[axis] + " (toward " + direction_word(axis, sign) + ")";
}

ExpertReference build_reference(const std::string& exercise, const std::vector<ProcessMetrics>& experts) {
  ExpertReference r;
  r.exercise = exercise;
  if (experts.empty()) return r;
  const std::size_t S = experts[0].steps.size();
  r.steps.resize(S);
  for (std::size_t k = 0; k < S; ++k) {
    StepReference& s = r.steps[k];
    s.name = experts[0].steps[k].name;
    std::vector<double> f[3], p[3], dr;
    Eigen::Vector3d axis_sum = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> axes;
    for (const auto& e : experts) {
      if (k >= e.steps.size() || e.steps[k].force.n < 10) continue;
      for (int a = 0; a < 3; ++a) {
        f[a].push_back(e.steps[k].force.mean(a));
        p[a].push_back(e.steps[k].tip_mean_mm(a));
      }
      dr.push_back(e.steps[k].drilling_s);
      axis_sum += e.steps[k].axis_mean;
      axes.push_back(e.steps[k].axis_mean);
    }
    s.sessions = static_cast<int>(dr.size());
    for (int a = 0; a < 3; ++a) {
      mean_sd(f[a], s.force_mean(a), s.force_sd(a));
      mean_sd(p[a], s.tip_mean_mm(a), s.tip_sd_mm(a));
    }
    mean_sd(dr, s.drilling_mean_s, s.drilling_sd_s);
    std::vector<double> mir, none;
    for (const auto& e : experts) {
      if (!e.mirror_tracked || k >= e.steps.size()) continue;
      const auto& v = e.steps[k].views;
      const int n = v[0] + v[1] + v[2] + v[3];
      if (n < 10) continue;  // too few classified drilling frames to say how this expert looked
      mir.push_back(100.0 * (v[1] + v[2]) / n);
      none.push_back(100.0 * v[3] / n);
    }
    s.view_sessions = static_cast<int>(mir.size());
    mean_sd(mir, s.mirror_pct_mean, s.mirror_pct_sd);
    mean_sd(none, s.no_sight_pct_mean, s.no_sight_pct_sd);
    if (axis_sum.norm() > 0) s.axis_mean = axis_sum.normalized();
    std::vector<double> ang;
    for (const auto& a : axes) ang.push_back(std::acos(std::clamp(a.dot(s.axis_mean), -1.0, 1.0)) * 180 / M_PI);
    double m;
    mean_sd(ang, m, s.axis_sd_deg);
    s.axis_sd_deg = std::sqrt(m * m + s.axis_sd_deg * s.axis_sd_deg);
  }
  std::vector<double> d, pa, dr, ex;
  for (const auto& e : experts) {
    d.push_back(e.duration_s);
    pa.push_back(e.path_mm);
    dr.push_back(e.drilling_s);
    ex.push_back(e.excessive_force_s);
  }
  mean_sd(d, r.duration_mean_s, r.duration_sd_s);
  mean_sd(pa, r.path_mean_mm, r.path_sd_mm);
  mean_sd(dr, r.drilling_mean_s, r.drilling_sd_s);
  mean_sd(ex, r.excessive_mean_s, r.excessive_sd_s);
  return r;
}

std::string reference_to_json(const ExpertReference& r) {
  using nlohmann::json;
  auto v3 = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json j = {{"format", "dentar-expert-reference"}, {"version", 1}, {"exercise", r.exercise},
            {"duration_s", {r.duration_mean_s, r.duration_sd_s}}, {"path_mm", {r.path_mean_mm, r.path_sd_mm}},
            {"drilling_s", {r.drilling_mean_s, r.drilling_sd_s}}, {"excessive_force_s", {r.excessive_mean_s, r.excessive_sd_s}}};
  j["steps"] = json::array();
  for (const auto& s : r.steps)
    j["steps"].push_back({{"name", s.name}, {"sessions", s.sessions}, {"force_mean_N", v3(s.force_mean)},
                          {"force_sd_N", v3(s.force_sd)}, {"tip_mean_mm", v3(s.tip_mean_mm)}, {"tip_sd_mm", v3(s.tip_sd_mm)},
                          {"axis_mean", v3(s.axis_mean)}, {"axis_sd_deg", s.axis_sd_deg},
                          {"drilling_s", {s.drilling_mean_s, s.drilling_sd_s}}, {"view_sessions", s.view_sessions},
                          {"mirror_pct", {s.mirror_pct_mean, s.mirror_pct_sd}},
                          {"no_sight_pct", {s.no_sight_pct_mean, s.no_sight_pct_sd}}});
  return j.dump(1);
}

Result<ExpertReference> reference_from_json(const std::string& text, const std::string& name) {
  using nlohmann::json;
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("format", "") != "dentar-expert-reference")
    return Error{name + ": not an expert reference (field 'format' must be \"dentar-expert-reference\")"};
  ExpertReference r;
  try {
    r.exercise = j.at("exercise").get<std::string>();
    auto pair = [&](const char* k, double& m, double& s) {
      m = j.at(k).at(0).get<double>();
      s = j.at(k).at(1).get<double>();
    };
    pair("duration_s", r.duration_mean_s, r.duration_sd_s);
    pair("path_mm", r.path_mean_mm, r.path_sd_mm);
    pair("drilling_s", r.drilling_mean_s, r.drilling_sd_s);
    pair("excessive_force_s", r.excessive_mean_s, r.excessive_sd_s);
    auto v3 = [](const json& a) { return Eigen::Vector3d(a.at(0).get<double>(), a.at(1).get<double>(), a.at(2).get<double>()); };
    for (const auto& s : j.at("steps")) {
      StepReference t;
      t.name = s.at("name").get<std::string>();
      t.sessions = s.at("sessions").get<int>();
      t.force_mean = v3(s.at("force_mean_N"));
      t.force_sd = v3(s.at("force_sd_N"));
      t.tip_mean_mm = v3(s.at("tip_mean_mm"));
      t.tip_sd_mm = v3(s.at("tip_sd_mm"));
      t.axis_mean = v3(s.at("axis_mean"));
      t.axis_sd_deg = s.at("axis_sd_deg").get<double>();
      t.drilling_mean_s = s.at("drilling_s").at(0).get<double>();
      t.drilling_sd_s = s.at("drilling_s").at(1).get<double>();
      if (s.contains("view_sessions")) {  // optional: references without expert views give no mirror advice
        t.view_sessions = s.at("view_sessions").get<int>();
        t.mirror_pct_mean = s.at("mirror_pct").at(0).get<double>();
        t.mirror_pct_sd = s.at("mirror_pct").at(1).get<double>();
        t.no_sight_pct_mean = s.at("no_sight_pct").at(0).get<double>();
        t.no_sight_pct_sd = s.at("no_sight_pct").at(1).get<double>();
      }
      r.steps.push_back(t);
    }
  } catch (const json::exception& e) {
    return Error{name + ": " + e.what()};
  }
  return r;
}

std::vector<FeedbackMessage> tutoring_feedback(const ProcessMetrics& st, const ExpertReference& ref,
                                               double excessive_force_N, const FeedbackRules& R) {
  std::vector<FeedbackMessage> out;
  const std::size_t S = std::min(st.steps.size(), ref.steps.size());
  // Mirror use of a step against the experts' (docs/formats.md, "Tutoring
  // feedback"): only where both the student's and the experts' views were measured.
  auto mirror_advice = [&](std::size_t, const StepMetrics& s, const StepReference& e, const auto& add) {
    if (!st.mirror_tracked || e.view_sessions < 1) return;
    const auto& v = s.views;
    const int n = v[0] + v[1] + v[2] + v[3];
    if (n < R.min_view_frames) return;
    const double fm = 100.0 * (v[1] + v[2]) / n, fd = 100.0 * v[0] / n, fn = 100.0 * v[3] / n;
    const double sd = std::max(e.mirror_pct_sd, R.min_sd_pct);
    const std::string experts = "experts " + num(e.mirror_pct_mean, 0) + " +/- " + num(sd, 0) + " %";
    if (e.mirror_pct_mean >= R.mirror_step_pct) {  // the experts work this site in indirect vision
      if (fm < e.mirror_pct_mean - R.band_sd * sd) {
        std::string how = fd >= fn ? "; you looked at it directly in " + num(fd, 0) +
                                         " % of them: bend less and let the mirror show it"
                                   : "; you worked without sight of it in " + num(fn, 0) + " % of them";
        add("instruct", "use the mirror for this step: you saw the site in the mirror in " + num(fm, 0) +
                            " % of your drilling frames, " + experts + how + ".");
      } else {
        add("well_done", "well done: you worked in the mirror in " + num(fm, 0) + " % of your drilling frames (" +
                             experts + ").");
      }
    } else {
      const double nsd = std::max(e.no_sight_pct_sd, R.min_sd_pct);
      if (fn > R.no_sight_pct && fn > e.no_sight_pct_mean + 2 * nsd)
        add("caution", "you could not see the site in " + num(fn, 0) + " % of your drilling frames (experts " +
                           num(e.no_sight_pct_mean, 0) + " +/- " + num(nsd, 0) +
                           " %): use the mirror or change your position.");
    }
  };
  for (std::size_t k = 0; k < S; ++k) {
    const StepMetrics& s = st.steps[k];
    const StepReference& e = ref.steps[k];
    const std::string label = "Step " + std::to_string(k + 1) + " (" + s.name + "): ";
    auto add = [&](const std::string& kind, const std::string& text) {
      out.push_back({static_cast<int>(k), s.name, kind, label + text});
    };
    if (e.sessions < 1) continue;
    if (s.force.n < R.min_frames) {
      add("caution", "no drilling with contact found in this step; it was skipped or done elsewhere.");
      continue;
    }
    int main = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(e.force_mean(a)) > std::abs(e.force_mean(main))) main = a;
    const double sign = e.force_mean(main) >= 0 ? 1 : -1;
    const double em = std::abs(e.force_mean(main));
    const double esd = std::max(e.force_sd(main), R.min_sd_N);
    const double sm = s.force.mean(main) * sign;  // student's force along the experts' main direction
    const std::string dir = axis_direction_name(main, sign);
    const std::string band = num(em, 2) + " +/- " + num(esd, 2) + " N";
    bool main_ok = std::abs(sm - em) <= R.band_sd * esd;
    bool any = false;
    if (!main_ok && sm < em) {
      any = true;
      const double cap = std::min(R.max_multiplier, sm > 1e-3 ? excessive_force_N / sm : R.max_multiplier);
      double mult = sm > 1e-3 ? em / sm : R.max_multiplier;
      const bool capped = mult > cap;
      mult = std::min(mult, cap);
      add("instruct", "force in " + dir + " should be " + num(mult) + " times higher (you: " + num(std::max(sm, 0.0), 2) +
                          " N, experts: " + band + ")" +
                          (capped ? "; raise it gradually, more than " + num(cap * sm, 1) + " N could damage the tooth." : "."));
    } else if (!main_ok) {
      any = true;
      add("instruct", "force in " + dir + " should be " + num(sm / std::max(em, 1e-3)) +
                          " times lower (you: " + num(sm, 2) + " N, experts: " + band + ").");
    }
    for (int a = 0; a < 3; ++a) {
      if (a == main) continue;
      const double sv = s.force.mean(a), ev = e.force_mean(a), sd = std::max(e.force_sd(a), R.min_sd_N);
      if (std::abs(sv - ev) > 2 * sd && std::abs(sv) > R.off_axis_ratio * std::max(std::abs(sm), 1e-3)) {
        any = true;
        if (main_ok)
          add("ask", "do you know that " + dir + " should be the main direction of force in this stage? Your force along " +
                         axis_direction_name(a, sv) + " was " + num(std::abs(sv), 2) + " N, experts " + num(ev, 2) +
                         " +/- " + num(sd, 2) + " N.");
        else
          add("instruct", "reduce the force along " + axis_direction_name(a, sv) + ": " + num(std::abs(sv), 2) +
                              " N, experts " + num(ev, 2) + " +/- " + num(sd, 2) + " N.");
      }
    }
    const Eigen::Vector3d dp = s.tip_mean_mm - e.tip_mean_mm;
    const double dist = dp.norm();
    if (dist > R.position_mm && dist > 2 * e.tip_sd_mm.norm()) {
      any = true;
      int a = 0;
      dp.cwiseAbs().maxCoeff(&a);
      add("instruct", "you worked " + num(dist) + " mm away from where the experts work, mostly toward " +
                          direction_word(a, dp(a)) + " (" + num(std::abs(dp(a))) + " mm).");
    }
    const double ang = std::acos(std::clamp(s.axis_mean.dot(e.axis_mean), -1.0, 1.0)) * 180 / M_PI;
    if (s.axis_mean.norm() > 0 && ang > R.angle_deg && ang > 2 * e.axis_sd_deg) {
      any = true;
      const Eigen::Vector3d d = s.axis_mean - e.axis_mean;
      int a = 0;
      d.head<2>().cwiseAbs().maxCoeff(&a);
      add("instruct", "the bur axis was " + num(ang, 0) + " degrees off the experts' axis, tilted toward " +
                          direction_word(a, -d(a)) + "; hold the handpiece more like the experts.");
    }
    if (e.drilling_sd_s >= 0 && s.drilling_s > e.drilling_mean_s + 2 * std::max(e.drilling_sd_s, 0.1 * e.drilling_mean_s)) {
      any = true;
      add("instruct", "drilling took " + num(s.drilling_s) + " s; experts " + num(e.drilling_mean_s) + " +/- " +
                          num(e.drilling_sd_s) + " s.");
    }
    if (!any) add("well_done", "well done: force in " + dir + " " + num(sm, 2) + " N, within the experts' " + band + ".");
    mirror_advice(k, s, e, add);
  }
  if (st.excessive_force_s > ref.excessive_mean_s + 2 * ref.excessive_sd_s + 0.1)
    out.push_back({-1, "", "caution", "You drilled with more than " + num(excessive_force_N) + " N for " +
                                          num(st.excessive_force_s) + " s (experts " + num(ref.excessive_mean_s) + " s)."});
  if (ref.path_sd_mm >= 0 && st.path_mm > ref.path_mean_mm + 2 * std::max(ref.path_sd_mm, 0.1 * ref.path_mean_mm))
    out.push_back({-1, "", "instruct", "Your bur travelled " + num(st.path_mm, 0) + " mm, experts " + num(ref.path_mean_mm, 0) +
                                           " +/- " + num(ref.path_sd_mm, 0) + " mm: plan the path between steps."});
  return out;
}

}  // namespace dentar::training
