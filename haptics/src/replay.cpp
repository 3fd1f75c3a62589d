#include "dentar/haptics/replay.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "dentar/haptics/replay_device.h"

namespace dentar::haptics {
namespace {

using nlohmann::json;

// Reads a required field, naming it on error.
template <typename T>
bool get(const json& j, const char* key, T& out, std::string& err) {
  if (!j.is_object() || !j.contains(key)) {
    err = std::string("field '") + key + "' is missing";
    return false;
  }
  try {
    out = j.at(key).get<T>();
  } catch (const json::exception&) {
    err = std::string("field '") + key + "' has the wrong type";
    return false;
  }
  return true;
}

bool get_iso(const json& j, const char* key, Eigen::Isometry3d& T, std::string& err) {
  std::vector<double> v;
  if (!get(j, key, v, err)) return false;
  if (v.size() != 16) {
    err = std::string("field '") + key + "' must hold 16 numbers (row-major 4x4)";
    return false;
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
  T.matrix() = m;
  return true;
}

}  // namespace

Result<SessionSetup> parse_session_header(const std::string& text) {
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Error{"session header: not a JSON object"};
  SessionSetup s;
  std::string err, fmt, shape;
  json seed, proxy, cut, bur, dev;
  auto fail = [&] { return Error{"session header: " + err}; };
  if (!get(j, "format", fmt, err)) return fail();
  if (fmt != "dentar-session") return Error{"session header: format '" + fmt + "' is not dentar-session"};
  auto& e = s.engine;
  if (!get(j, "rate_hz", e.rate_hz, err) || !get(j, "model", e.model, err) ||
      !get(j, "seed", seed, err) || !get(j, "proxy", proxy, err) || !get(j, "cut", cut, err) ||
      !get(j, "bur", bur, err) || !get(j, "device", dev, err) ||
      !get_iso(j, "T_tooth_dev", e.T_tooth_dev, err) ||
      !get_iso(j, "T_sty_tip", e.T_sty_tip, err) ||
      !get(j, "watchdog_missed_deadlines", e.watchdog_missed_deadlines, err) ||
      !get(j, "watchdog_rearm_steps", e.watchdog_rearm_steps, err) ||
      !get(j, "max_force_rate_N_per_s", e.max_force_rate_N_per_s, err))
    return fail();
  auto& sp = e.model_params.seed;
  auto& pp = e.model_params.proxy;
  if (!get(seed, "density_scale_N", sp.density_scale_N, err) || !get(seed, "c1_N", sp.c1_N, err) ||
      !get(seed, "c2_N_s_per_m", sp.c2_N_s_per_m, err) || !get(seed, "history", sp.history, err) ||
      !get(proxy, "stiffness_N_per_m", pp.stiffness_N_per_m, err) ||
      !get(proxy, "damping_N_s_per_m", pp.damping_N_s_per_m, err) ||
      !get(proxy, "max_cut_depth_m", pp.max_cut_depth_m, err) ||
      !get(cut, "base_rate_per_s", e.cut.base_rate_per_s, err) ||
      !get(cut, "reference_force_N", e.cut.reference_force_N, err) ||
      !get(cut, "max_effective_force_N", e.cut.max_effective_force_N, err) ||
      !get(cut, "min_force_N", e.cut.min_force_N, err) || !get(bur, "shape", shape, err) ||
      !get(bur, "radius_m", s.bur.radius_m, err) || !get(bur, "length_m", s.bur.length_m, err) ||
      !get(bur, "tip_radius_m", s.bur.tip_radius_m, err) ||
      !get(bur, "samples", s.bur_samples, err) || !get(bur, "id", e.bur_id, err) ||
      !get(dev, "max_force_N", s.limits.max_force_N, err) ||
      !get(dev, "max_stiffness_N_per_m", s.limits.max_stiffness_N_per_m, err))
    return fail();
  if (cut.contains("sample_jitter")) {  // optional: absent in sessions before session 20 (= false)
    if (!cut["sample_jitter"].is_boolean()) return Error{"session header: cut.sample_jitter must be true or false"};
    e.cut.sample_jitter = cut["sample_jitter"].get<bool>();
  }
  // Optional since session 22 (absent = false).
  if (cut.contains("overlap")) {
    if (!cut["overlap"].is_boolean()) return Error{"session header: cut.overlap must be true or false"};
    e.cut.overlap = cut["overlap"].get<bool>();
  }
  if (proxy.contains("shape_constraint")) {
    if (!proxy["shape_constraint"].is_boolean())
      return Error{"session header: proxy.shape_constraint must be true or false"};
    pp.shape_constraint = proxy["shape_constraint"].get<bool>();
  }
  std::vector<double> wmin, wmax;
  if (!get(dev, "workspace_min_m", wmin, err) || !get(dev, "workspace_max_m", wmax, err))
    return fail();
  if (wmin.size() != 3 || wmax.size() != 3) return Error{"session header: workspace needs 3 numbers"};
  s.limits.workspace_min_m = Eigen::Vector3d(wmin[0], wmin[1], wmin[2]);
  s.limits.workspace_max_m = Eigen::Vector3d(wmax[0], wmax[1], wmax[2]);
  auto sh = volume::parse_bur_shape(shape);
  if (!sh) return Error{"session header: bur." + sh.error()};
  s.bur.shape = *sh;
  std::string hash;
  if (!get(j, "volume_hash_start", hash, err)) return fail();
  char* end = nullptr;
  s.volume_hash_start = std::strtoull(hash.c_str(), &end, 16);
  if (hash.size() != 16 || !end || *end) return Error{"session header: volume_hash_start must be 16 hex digits"};
  s.tooth_json = j.contains("tooth") ? j["tooth"].dump() : "null";
  if (j.contains("training")) {
    json tj, g, tol, ex;
    TrainingSetup t;
    int mode = 0;
    std::vector<double> theta;
    std::string ehash;
    if (!get(j, "training", tj, err) || !get(tj, "mode", mode, err) || !get(tj, "guidance", g, err) ||
        !get(tj, "tolerance", tol, err) || !get(tj, "expert", ex, err) ||
        !get(tj, "conditional_replay", t.params.conditional_replay, err) || !get(tj, "speed", t.params.speed, err) ||
        !get(tj, "ramp_s", t.params.ramp_s, err))
      return Error{"session header: training: " + err};
    auto& gp = t.params.guidance;
    if (!get(g, "k_N_per_m", gp.k_N_per_m, err) || !get(g, "eps1_m", gp.eps1_m, err) ||
        !get(g, "eps2_m", gp.eps2_m, err) || !get(g, "damping_N_s_per_m", gp.damping_N_s_per_m, err) ||
        !get(g, "across_path_only", gp.across_path_only, err) || !get(g, "quadratic_core", gp.quadratic_core, err) ||
        !get(g, "as_needed", gp.as_needed, err) || !get(g, "as_needed_gain", gp.as_needed_gain, err) ||
        !get(g, "as_needed_min", gp.as_needed_min, err) || !get(g, "as_needed_tau_s", gp.as_needed_tau_s, err) ||
        !get(g, "fade", gp.fade, err) || !get(g, "repetition", gp.repetition, err) ||
        !get(g, "amplify", gp.amplify, err) || !get(tol, "eps_m", t.params.tolerance.eps_m, err) ||
        !get(tol, "theta_rad", theta, err) || !get(ex, "file", t.params.expert_file, err) ||
        !get(ex, "hash", ehash, err) || !get_iso(ex, "T_tooth_dev", t.expert_T_tooth_dev, err) ||
        !get_iso(ex, "T_sty_tip", t.expert_T_sty_tip, err))
      return Error{"session header: training: " + err};
    if (theta.size() != 3) return Error{"session header: training: tolerance.theta_rad needs 3 numbers"};
    for (int i = 0; i < 3; ++i) t.params.tolerance.theta_rad[i] = theta[static_cast<std::size_t>(i)];
    if (mode < 1 || mode > 5) return Error{"session header: training: mode " + std::to_string(mode) + " must be 1..5"};
    t.params.mode = static_cast<TrainingModeKind>(mode);
    char* hend = nullptr;
    t.expert_hash = std::strtoull(ehash.c_str(), &hend, 16);
    if (ehash.size() != 16 || !hend || *hend)
      return Error{"session header: training: expert.hash must be 16 hex digits"};
    if (std::string v = t.params.validate(); !v.empty()) return Error{"session header: training: " + v};
    s.training = t;
  }
  if (std::string v = e.validate(); !v.empty()) return Error{"session header: " + v};
  if (std::string v = s.limits.validate(); !v.empty()) return Error{"session header: device " + v};
  return s;
}

Result<ExpertTrack> load_trained_expert(const TrainingSetup& t) {
  auto expert = read_session_log(t.params.expert_file);
  if (!expert) return Error{"the session was trained on " + t.params.expert_file + ": " + expert.error()};
  auto tr = ExpertTrack::from_records(expert->records, t.expert_T_tooth_dev, t.expert_T_sty_tip, t.params.expert_file);
  if (!tr) return Error{tr.error()};
  if (tr->content_hash() != t.expert_hash)
    return Error{t.params.expert_file +
                 " is not the expert recording this session was trained on (its content differs); "
                 "give the lesson's own recording"};
  return tr;
}

Result<ReplayResult> replay_session(const SessionLog& log, volume::VoxelVolume& vol) {
  auto setup = parse_session_header(log.header_json);
  if (!setup) return Error{setup.error()};
  if (vol.content_hash() != setup->volume_hash_start) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "replay: the volume (hash %016llx) is not the session's starting volume (%016llx)",
                  static_cast<unsigned long long>(vol.content_hash()),
                  static_cast<unsigned long long>(setup->volume_hash_start));
    return Error{buf};
  }
  auto bur = volume::sample_bur(setup->bur, setup->bur_samples);
  if (!bur) return Error{"replay: " + bur.error()};
  ReplayDevice dev(log.records, setup->limits);
  // A trained session: the expert recording it replayed, checked, and the mode rebuilt.
  std::optional<ExpertTrack> track;
  std::optional<TrainingMode> mode;
  if (setup->training) {
    auto tr = load_trained_expert(*setup->training);
    if (!tr) return Error{"replay: " + tr.error()};
    track.emplace(std::move(tr).value());
    auto m = TrainingMode::create(setup->training->params, *track);
    if (!m) return Error{"replay: " + m.error()};
    mode.emplace(std::move(m).value());
    setup->engine.training = &*mode;
  }
  auto engine = Engine::create(setup->engine, dev, vol, *bur, nullptr);
  if (!engine) return Error{"replay: " + engine.error()};
  ReplayResult r;
  r.steps = (*engine)->run_steps(log.records.size());
  r.volume_hash = vol.content_hash();
  r.max_force_difference_N = dev.max_force_difference_N();
  r.metrics = (*engine)->cutter().metrics();
  r.stats = (*engine)->stats();
  return r;
}

}  // namespace dentar::haptics
