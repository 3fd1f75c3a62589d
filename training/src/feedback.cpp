#include "dentar/training/feedback.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

namespace dentar::training {
namespace {

std::string num(double v, int prec = 1) {
  if (std::abs(v) < 0.5 * std::pow(10.0, -prec)) v = 0;  // never "-0.00"
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
  r.sessions = static_cast<int>(experts.size());
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
  json j = {{"format", "dentar-expert-reference"}, {"version", 1}, {"exercise", r.exercise}, {"sessions", r.sessions},
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
    // Older references: the largest step count stands for the whole.
    if (j.contains("sessions")) {
      r.sessions = j.at("sessions").get<int>();
    } else {
      for (const auto& t : r.steps) r.sessions = std::max(r.sessions, t.sessions);
    }
  } catch (const json::exception& e) {
    return Error{name + ": " + e.what()};
  }
  return r;
}

std::vector<FeedbackMessage> tutoring_feedback(const ProcessMetrics& st, const ExpertReference& ref,
                                               double excessive_force_N, const FeedbackRules& R) {
  // Rules and an example of each message: docs/feedback.md.
  std::vector<FeedbackMessage> out;
  const std::size_t S = std::min(st.steps.size(), ref.steps.size());
  if (ref.sessions < R.min_ref_sessions) {
    // Say why nothing is compared, rather than nothing at all.
    out.push_back({-1, "", "caution",
                   "The expert reference holds " + std::to_string(ref.sessions) + " expert session" +
                       (ref.sessions == 1 ? "" : "s") + ": at least " + std::to_string(R.min_ref_sessions) +
                       " are needed for a mean and a spread, so no step is compared with the experts.",
                   "reference_too_small", -1, 0});
    return out;
  }
  auto mirror_advice = [&](const StepMetrics& s, const StepReference& e, const auto& add) {
    if (!st.mirror_tracked || e.view_sessions < R.min_ref_sessions) return;
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
        add("instruct", "mirror_use",
            "use the mirror for this step: you saw the site in the mirror in " + num(fm, 0) +
                " % of your drilling frames, " + experts + how + ".", -1, 0);
      } else {
        add("well_done", "mirror_ok",
            "well done: you worked in the mirror in " + num(fm, 0) + " % of your drilling frames (" + experts + ").", -1, 0);
      }
    } else {
      const double nsd = std::max(e.no_sight_pct_sd, R.min_sd_pct);
      if (fn > R.no_sight_pct && fn > e.no_sight_pct_mean + 2 * nsd)
        add("caution", "no_sight",
            "you could not see the site in " + num(fn, 0) + " % of your drilling frames (experts " +
                num(e.no_sight_pct_mean, 0) + " +/- " + num(nsd, 0) + " %): use the mirror or change your position.",
            -1, 0);
    }
  };
  for (std::size_t k = 0; k < S; ++k) {
    const StepMetrics& s = st.steps[k];
    const StepReference& e = ref.steps[k];
    const std::string label = "Step " + std::to_string(k + 1) + " (" + s.name + "): ";
    auto add = [&](const std::string& kind, const std::string& rule, const std::string& text, int axis, int sign) {
      out.push_back({static_cast<int>(k), s.name, kind, label + text, rule, axis, sign});
    };
    // Too few expert sessions for a mean and an SD: nothing is said.
    if (e.sessions < R.min_ref_sessions) continue;
    if (s.force.n < R.min_frames) {
      add("caution", "no_contact", "no drilling with contact found in this step; it was skipped or done elsewhere.", -1, 0);
      continue;
    }
    int main = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(e.force_mean(a)) > std::abs(e.force_mean(main))) main = a;
    const int sign = e.force_mean(main) >= 0 ? 1 : -1;
    const double em = std::abs(e.force_mean(main));
    const double esd = std::max(e.force_sd(main), R.min_sd_N);
    const double sm = s.force.mean(main) * sign;  // student's force along the experts' main direction
    const std::string dir = axis_direction_name(main, sign);
    const std::string band = num(em, 2) + " +/- " + num(esd, 2) + " N";
    // Experts that hardly press along any axis give no main direction: only
    // a student who presses clearly more is told to press more lightly.
    const bool experts_press = em >= R.min_force_N;
    const double sv_main = s.force.mean(main);
    const bool main_ok = experts_press ? std::abs(sm - em) <= R.band_sd * esd
                                       : std::abs(sv_main) <= em + R.band_sd * esd;
    bool any = false;
    if (!experts_press) {
      if (!main_ok) {
        any = true;
        const int ss = sv_main >= 0 ? 1 : -1;
        add("instruct", "force_high",
            "press more lightly along " + axis_direction_name(main, ss) + ": you " + num(std::abs(sv_main), 2) +
                " N, the experts hardly press (" + band + ").",
            main, ss);
      }
    } else if (!main_ok && sm < em) {
      any = true;
      if (sm < -R.min_force_N) {
        // Pressing the other way: no multiplier makes sense.
        add("instruct", "force_opposite",
            "your force pointed the other way, " + num(-sm, 2) + " N along " + axis_direction_name(main, -sign) +
                "; the experts press along " + dir + " (" + band + ").",
            main, -sign);
      } else if (sm < R.min_force_N) {
        add("instruct", "force_none",
            "you pressed almost nothing along " + dir + " (" + num(std::max(sm, 0.0), 2) + " N, experts " + band +
                "); press gradually toward the experts' force.",
            main, sign);
      } else {
        // The goal: the experts' mean, never above the exercise's excessive force.
        const double goal = std::min(em, excessive_force_N);
        double mult = goal / sm;
        const bool capped = mult > R.max_multiplier || goal < em;
        mult = std::min(mult, R.max_multiplier);
        if (mult >= 1.1) {
          add("instruct", "force_low",
              "force in " + dir + " should be " + num(mult) + " times higher (you: " + num(sm, 2) + " N, experts: " + band +
                  ")" + (capped ? "; raise it gradually, up to " + num(mult * sm, 2) + " N at most this time." : "."),
              main, sign);
        } else if (!capped) {
          add("instruct", "force_low",
              "force in " + dir + " should be a little higher (you: " + num(sm, 2) + " N, experts: " + band + ").", main,
              sign);
        }
        // else: already at the most the exercise allows: nothing to ask for,
        // and no "well done" either (the force is still below the experts').

      }
    } else if (!main_ok) {
      any = true;
      if (sm / em < 1.1) {
        add("instruct", "force_high",
            "force in " + dir + " should be a little lower (you: " + num(sm, 2) + " N, experts: " + band + ").", main, sign);
      } else {
        add("instruct", "force_high",
            "force in " + dir + " should be " + num(sm / em) + " times lower (you: " + num(sm, 2) + " N, experts: " + band +
                ").",
            main, sign);
      }
    }
    for (int a = 0; a < 3; ++a) {
      if (a == main) continue;
      const double sv = s.force.mean(a), ev = e.force_mean(a), sd = std::max(e.force_sd(a), R.min_sd_N);
      const int sa = sv >= 0 ? 1 : -1;
      const double mag = std::abs(sv), ep = ev * sa;  // the experts' force along the student's direction
      // Only a force larger than the experts' along the same direction is "too much".
      if (mag - ep > 2 * sd && mag > R.off_axis_ratio * std::max(std::abs(sm), R.min_force_N)) {
        any = true;
        const std::string theirs = std::abs(ev) < 0.005 ? "experts almost none (+/- " + num(sd, 2) + " N)"
                                   : ep >= 0 ? "experts " + num(ep, 2) + " +/- " + num(sd, 2) + " N that way"
                                             : "experts " + num(-ep, 2) + " +/- " + num(sd, 2) + " N the other way, along " +
                                                   axis_direction_name(a, -sa);
        if (main_ok)
          add("ask", "off_axis",
              "do you know that " + dir + " should be the main direction of force in this stage? Your force along " +
                  axis_direction_name(a, sa) + " was " + num(mag, 2) + " N, " + theirs + ".",
              a, sa);
        else
          add("instruct", "off_axis",
              "reduce the force along " + axis_direction_name(a, sa) + ": you " + num(mag, 2) + " N, " + theirs + ".", a,
              sa);
      }
    }
    const Eigen::Vector3d dp = s.tip_mean_mm - e.tip_mean_mm;
    const double dist = dp.norm();
    if (dist > R.position_mm && dist > 2 * e.tip_sd_mm.norm()) {
      any = true;
      int a = 0;
      dp.cwiseAbs().maxCoeff(&a);
      const std::string where = num(dist) + " mm away from where the experts work, mostly toward " +
                                direction_word(a, dp(a)) + " (" + num(std::abs(dp(a))) + " mm)";
      if (main_ok)
        add("ask", "position", "did you mean to work " + where + "?", -1, 0);
      else
        add("instruct", "position", "you worked " + where + ".", -1, 0);
    }
    const double ang = std::acos(std::clamp(s.axis_mean.dot(e.axis_mean), -1.0, 1.0)) * 180 / M_PI;
    if (s.axis_mean.norm() > 0 && ang > R.angle_deg && ang > 2 * e.axis_sd_deg) {
      any = true;
      const Eigen::Vector3d d = s.axis_mean - e.axis_mean;
      int a = 0;
      d.head<2>().cwiseAbs().maxCoeff(&a);
      const std::string tilt = num(ang, 0) + " degrees off the experts' axis, tilted toward " + direction_word(a, -d(a));
      if (main_ok)
        add("ask", "angle", "the bur axis was " + tilt + ": is that how the experts hold the handpiece here?", -1, 0);
      else
        add("instruct", "angle", "the bur axis was " + tilt + "; hold the handpiece more like the experts.", -1, 0);
    }
    const double dsd = std::max(e.drilling_sd_s, 0.1 * e.drilling_mean_s);
    if (e.drilling_mean_s > 0 && s.drilling_s > e.drilling_mean_s + 2 * dsd) {
      any = true;
      add("instruct", "drilling_time",
          "drilling took " + num(s.drilling_s) + " s; experts " + num(e.drilling_mean_s) + " +/- " + num(dsd) + " s.", -1, 0);
    }
    if (!any)
      add("well_done", "force_ok",
          sm >= 0 ? "well done: force in " + dir + " " + num(sm, 2) + " N, within the experts' " + band + "."
                  : "well done: your force along " + dir + " is within the experts' " + band + ".",
          main, sign);
    mirror_advice(s, e, add);
  }
  {
    const double xsd = std::max(ref.excessive_sd_s, 0.1);
    if (st.excessive_force_s > ref.excessive_mean_s + 2 * xsd && st.excessive_force_s >= 0.05)
      out.push_back({-1, "", "caution",
                     "You drilled with more than " + num(excessive_force_N) + " N for " + num(st.excessive_force_s) +
                         " s (experts " + num(ref.excessive_mean_s) + " +/- " + num(xsd) + " s).",
                     "excessive_force", -1, 0});
    const double psd = std::max(ref.path_sd_mm, 0.1 * ref.path_mean_mm);
    if (ref.path_mean_mm > 0 && st.path_mm > ref.path_mean_mm + 2 * psd)
      out.push_back({-1, "", "instruct",
                     "Your bur travelled " + num(st.path_mm, 0) + " mm, experts " + num(ref.path_mean_mm, 0) + " +/- " +
                         num(psd, 0) + " mm: plan the path between steps.",
                     "path", -1, 0});
  }
  return out;
}

namespace {
bool experts_press_any(const StepReference& e, const FeedbackRules& R) {
  return e.force_mean.cwiseAbs().maxCoeff() >= R.min_force_N;
}
}  // namespace

std::vector<std::string> feedback_violations(const ProcessMetrics& st, const ExpertReference& ref,
                                             double excessive_force_N, const std::vector<FeedbackMessage>& msgs,
                                             const FeedbackRules& R) {
  std::vector<std::string> bad;
  auto fail = [&](const FeedbackMessage& m, const std::string& why) { bad.push_back(why + ": \"" + m.text + "\""); };
  // The number right before a word ("3.0 times", "0.38 N").
  auto numbers_before = [](const std::string& t, const std::string& word) {
    std::vector<double> v;
    for (std::size_t p = t.find(word); p != std::string::npos; p = t.find(word, p + 1)) {
      std::size_t e = p;
      while (e > 0 && t[e - 1] == ' ') --e;
      std::size_t b = e;
      while (b > 0 && (std::isdigit(static_cast<unsigned char>(t[b - 1])) || t[b - 1] == '.')) --b;
      if (b < e) v.push_back(std::strtod(t.substr(b, e - b).c_str(), nullptr));
    }
    return v;
  };
  static const char* kRules[] = {"force_low", "force_none", "force_opposite", "force_high", "force_ok", "off_axis",
                                 "position", "angle", "drilling_time", "no_contact", "mirror_use", "mirror_ok",
                                 "no_sight", "excessive_force", "path", "reference_too_small"};
  std::map<int, std::vector<const FeedbackMessage*>> by_step;
  for (const auto& m : msgs) {
    by_step[m.step].push_back(&m);
    if (std::find(std::begin(kRules), std::end(kRules), m.rule) == std::end(kRules)) fail(m, "undocumented rule '" + m.rule + "'");
    if (m.kind != "well_done" && m.kind != "instruct" && m.kind != "ask" && m.kind != "caution") fail(m, "unknown kind");
    {
      std::string word;
      for (char ch : m.text + " ") {
        if (std::isalpha(static_cast<unsigned char>(ch))) {
          word += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
          continue;
        }
        if (word == "nan" || word == "inf" || word == "infinity") fail(m, "not a number");
        word.clear();
      }
    }
    // Rule 1: multipliers finite, >= 1.1.
    for (double x : numbers_before(m.text, " times"))
      if (!std::isfinite(x) || x < 1.1) fail(m, "multiplier " + num(x, 2) + " (must be >= 1.1)");
    // Rule 2: no limit of 0 N.
    for (const char* w : {"up to ", "more than "})
      for (std::size_t p = m.text.find(w); p != std::string::npos; p = m.text.find(w, p + 1)) {
        const double x = std::strtod(m.text.c_str() + p + std::strlen(w), nullptr);
        if (!(x > 0)) fail(m, std::string("a limit of ") + num(x, 2) + " N");
      }
    // Rule 3a: no negative numbers: the direction words carry the sign.
    for (std::size_t i = 0; i + 1 < m.text.size(); ++i)
      if (m.text[i] == '-' && std::isdigit(static_cast<unsigned char>(m.text[i + 1])) && (i == 0 || m.text[i - 1] != '/'))
        fail(m, "a negative number (say the direction instead)");
    if (m.axis >= 0 && m.text.find(axis_direction_name(m.axis, m.sign)) == std::string::npos)
      fail(m, "the direction named in the text is not " + axis_direction_name(m.axis, m.sign));
    if (m.step < 0) {
      // Rule 5 (whole session): enough expert sessions.
      if (m.rule != "reference_too_small" && ref.sessions < R.min_ref_sessions)
        fail(m, "a whole-session statistic from " + std::to_string(ref.sessions) + " expert sessions");
      if (m.rule == "reference_too_small" && ref.sessions >= R.min_ref_sessions) fail(m, "'too few experts' with enough");
      continue;
    }
    if (m.step >= static_cast<int>(std::min(st.steps.size(), ref.steps.size()))) {
      fail(m, "a step that has no statistics");
      continue;
    }
    const StepMetrics& s = st.steps[static_cast<std::size_t>(m.step)];
    const StepReference& e = ref.steps[static_cast<std::size_t>(m.step)];
    // Rule 5: nothing from too few samples.
    if (e.sessions < R.min_ref_sessions) fail(m, "an expert band from " + std::to_string(e.sessions) + " sessions");
    if (m.rule != "no_contact" && s.force.n < R.min_frames) fail(m, "a force from " + num(s.force.n, 0) + " frames");
    if (m.rule.rfind("mirror", 0) == 0 || m.rule == "no_sight") {
      const int n = s.views[0] + s.views[1] + s.views[2] + s.views[3];
      if (!st.mirror_tracked || e.view_sessions < R.min_ref_sessions || n < R.min_view_frames)
        fail(m, "mirror advice from too few views");
    }
    // Rule 3b: the words agree with the numbers.
    if (m.axis >= 0) {
      const double sv = s.force.mean(m.axis), ev = e.force_mean(m.axis);
      const double s_along = sv * m.sign, e_along = ev * m.sign;
      if (m.rule == "off_axis" && !(s_along > 0 && s_along > e_along)) fail(m, "'reduce' a force that is not larger than the experts' that way");
      if (m.rule == "force_low" && !(s_along < e_along)) fail(m, "'higher' while the student's force is not below the experts'");
      if (m.rule == "force_high" && !(s_along > e_along)) fail(m, "'lower' while the student's force is not above the experts'");
      if (m.rule == "force_opposite" && !(s_along > 0 && e_along < 0)) fail(m, "'the other way' while the forces agree");
      if (m.rule == "force_opposite" && !experts_press_any(e, R)) fail(m, "'the other way' while the experts hardly press");
      if (m.rule == "force_none" && !(s_along < R.min_force_N && s_along >= -R.min_force_N))
        fail(m, "'almost nothing' for a real force");
      const bool experts_press = std::abs(ev) >= R.min_force_N;
      if ((m.rule == "force_low" || m.rule == "force_opposite" || ((m.rule == "force_high" || m.rule == "force_ok") && experts_press)) &&
          !(std::abs(ev) > 0 && (m.rule == "force_opposite" ? e_along < 0 : e_along > 0)))
        fail(m, "the main direction is not the experts'");
    }
    if (m.rule == "force_low") {
      for (const char* w : {"up to "})
        for (std::size_t p = m.text.find(w); p != std::string::npos; p = m.text.find(w, p + 1))
          if (std::strtod(m.text.c_str() + p + std::strlen(w), nullptr) > excessive_force_N + 0.005)
            fail(m, "asks for more than the exercise's excessive force");
    }
  }
  // Rule 4: no contradictions within a step; rule 6: ask where the main force is right.
  for (const auto& [step, v] : by_step) {
    if (step < 0 || step >= static_cast<int>(std::min(st.steps.size(), ref.steps.size()))) continue;
    std::map<int, int> per_axis;
    bool ok = false, critic = false, main_msg = false;
    for (const FeedbackMessage* m : v) {
      if (m->axis >= 0 && m->rule != "force_ok") ++per_axis[m->axis];
      if (m->rule == "force_ok") ok = true;
      if (m->rule.rfind("force_", 0) == 0 && m->rule != "force_ok") main_msg = true;
      if (m->rule == "off_axis" || m->rule == "position" || m->rule == "angle" || m->rule == "drilling_time" ||
          (m->rule.rfind("force_", 0) == 0 && m->rule != "force_ok"))
        critic = true;
    }
    for (const auto& [a, n] : per_axis)
      if (n > 1) fail(*v.front(), "two force messages about the " + std::string(1, static_cast<char>('X' + a)) + " axis in one step");
    if (ok && critic) fail(*v.front(), "'well done' beside a correction in the same step");
    const StepMetrics& s = st.steps[static_cast<std::size_t>(step)];
    const StepReference& e = ref.steps[static_cast<std::size_t>(step)];
    int main = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(e.force_mean(a)) > std::abs(e.force_mean(main))) main = a;
    const double sg = e.force_mean(main) >= 0 ? 1 : -1;
    const bool main_ok = std::abs(s.force.mean(main) * sg - std::abs(e.force_mean(main))) <=
                         R.band_sd * std::max(e.force_sd(main), R.min_sd_N);
    if (main_ok && main_msg) fail(*v.front(), "a correction of a main force that is within the experts' band");
    if (main_ok)
      for (const FeedbackMessage* m : v)
        if ((m->rule == "off_axis" || m->rule == "position" || m->rule == "angle") && m->kind != "ask")
          fail(*m, "instructs where the main force was right (the seed asks)");
  }
  return bad;
}

}  // namespace dentar::training
