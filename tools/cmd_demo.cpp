// dentar demo: the trainer's main job on its built-in default (until the
// offline AR pipeline lands). A scripted drilling session on the procedural
// molar runs through the 1 kHz haptic engine in real time (simulated hand and
// device, foot pedal scripted), while this thread re-meshes dirty chunks at
// 30 Hz as the display would. The session log is then replayed in simulated
// time and the volume hashes compared. Prints removed volume per material,
// step-time percentiles and whether real-time priority was granted; writes
// the cut mesh (PLY) and the session log.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "commands.h"
#include "dentar/session/finish.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/simulated_device.h"
#include "sound_cli.h"
#include "dentar/training/exercise.h"
#include "dentar/training/hand_script.h"
#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"

namespace dentar::tools {
namespace {

using namespace dentar::volume;
using namespace dentar::haptics;
using Clock = std::chrono::steady_clock;

struct DemoOptions {
  double voxel_mm = 0.08;
  std::string bur = "capsule";
  double bur_radius_mm = 0.5;
  double bur_length_mm = 3.0;
  int samples = 10000;
  std::string model = "proxy";
  double force_N = 2.5;
  double seconds = 0;  // 0: the script's own length (~15 s)
  bool simulated = false;
  std::string out = "out/demo";
  bool obj = false;
  // The exercise drilled and scored: its tooth, its bur (unless --bur is given) and the
  // simulated hand's path through its steps. "" = the molar's scripted access, scored as
  // the molar access opening.
  std::string exercise;
  bool bur_given = false;  // --bur on the command line (overrides the exercise's bur)
  bool no_score = false;
  bool sample_jitter = true;  // CutParams::sample_jitter: on since session 21 (--no-sample-jitter: off)
  bool overlap_cut = true;    // haptics::use_overlap_cut: on since session 22 (--no-overlap-cut: off)
  SoundCli sound;  // issue 29: the drill's sound (live playback, --audio render)
};

std::string hex(std::uint64_t h) {
  std::ostringstream os;
  os << std::hex << std::setw(16) << std::setfill('0') << h;
  return os.str();
}

Result<BurParams> bur_params(const DemoOptions& o) {
  auto shape = parse_bur_shape(o.bur);
  if (!shape) return Error{"--bur: " + shape.error()};
  switch (*shape) {
    case BurShape::kSphere: return BurParams::sphere(o.bur_radius_mm);
    case BurShape::kCylinder: return BurParams::cylinder(o.bur_radius_mm, o.bur_length_mm);
    case BurShape::kCapsule: return BurParams::capsule(o.bur_radius_mm, o.bur_length_mm);
    case BurShape::kCone:
      return BurParams::cone(0.5 * o.bur_radius_mm, o.bur_radius_mm, o.bur_length_mm);
  }
  return Error{"--bur: unknown shape"};
}

// exposure_s: device time of the exposure (the cutter counts only its own
// steps, i.e. pedal-down steps).
void print_metrics(const CutMetrics& m, double exposure_s) {
  std::cout << std::fixed << std::setprecision(3) << "removed volume per material (mm^3):\n";
  for (int mat = 1; mat < kNumMaterials; ++mat)
    std::cout << "  " << std::setw(12) << std::left << material_name(static_cast<Material>(mat))
              << std::right << std::setw(10) << m.removed_mm3[static_cast<std::size_t>(mat)] << "\n";
  std::cout << "  " << std::setw(12) << std::left << "total" << std::right << std::setw(10)
            << m.removed_total_mm3 << "  (" << m.removed_percent << " % of "
            << m.original_tooth_mm3 << " mm^3)\n";
  if (m.pulp_exposure)
    std::cout << "pulp exposed at t = " << exposure_s << " s (cutting step "
              << m.pulp_exposure->step << "), tooth-frame position ("
              << m.pulp_exposure->position_m.x() * 1e3 << ", "
              << m.pulp_exposure->position_m.y() * 1e3 << ", "
              << m.pulp_exposure->position_m.z() * 1e3 << ") mm\n";
  else
    std::cout << "pulp not exposed\n";
}

int run_demo(const DemoOptions& o) {
  namespace fs = std::filesystem;
  // The tooth drilled: the exercise's (its kind at --voxel-mm), else the procedural molar.
  std::optional<training::Exercise> ex;
  nlohmann::json tooth_desc = {{"kind", "molar"}, {"voxel_mm", o.voxel_mm}};
  if (!o.exercise.empty()) {
    auto e = training::load_named_exercise(o.exercise);
    if (!e) {
      print_error("demo", "--exercise " + o.exercise + ": " + e.error());
      return 2;
    }
    ex = std::move(*e);
    auto td = nlohmann::json::parse(ex->tooth_json, nullptr, false);
    if (!td.is_object()) td = nlohmann::json::object();
    td["voxel_mm"] = o.voxel_mm;
    tooth_desc = td;
  }
  auto tooth = training::make_tooth(tooth_desc.dump());
  if (!tooth) {
    print_error("demo", tooth.error());
    return 2;
  }
  VoxelVolume& vol = *tooth;
  const std::uint64_t start_hash = vol.content_hash();
  auto bp = ex && !o.bur_given ? Result<BurParams>(ex->bur) : bur_params(o);
  if (!bp) {
    print_error("demo", bp.error());
    return 2;
  }
  auto bur = sample_bur(*bp, o.samples);
  if (!bur) {
    print_error("demo", bur.error() + " (check --bur-radius-mm, --bur-length-mm, --samples)");
    return 2;
  }
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    print_error("demo", "cannot create output folder '" + o.out + "': " + ec.message());
    return 1;
  }
  session::remove_old_score(o.out);
  std::cout << "tooth: " << (ex ? "the " + tooth_desc.value("kind", std::string("molar")) + " of exercise " + ex->name
                              : std::string("procedural maxillary molar"))
            << ", " << vol.dims().x() << "x" << vol.dims().y()
            << "x" << vol.dims().z() << " voxels of " << o.voxel_mm << " mm, "
            << vol.allocated_chunks() << "/" << vol.num_chunks() << " chunks allocated ("
            << vol.memory_bytes() / 1e6 << " MB vs " << vol.dense_bytes() / 1e6 << " MB dense)\n";
  std::cout << "bur: " << bur_shape_name(bp->shape) << " r=" << bp->radius_m * 1e3
            << " mm L=" << bp->length_m * 1e3 << " mm, " << bur->size() << " samples; model "
            << o.model << "\n";

  const Station station = default_station();
  DeviceLimits limits;
  HandParams hand;
  hand.stiffness_N_per_m = kFingerRestStiffness_N_per_m;
  // The simulated hand: the molar's scripted access, or an expert pass through the
  // exercise's steps (training/hand_script.h, as `dentar live --stylus sim --exercise`).
  std::vector<TipWaypoint> tips;
  if (ex) {
    auto t = training::expert_tip_script(*ex, vol);
    if (!t) {
      print_error("demo", "--exercise " + o.exercise + ": simulated hand: " + t.error());
      return 1;
    }
    tips = std::move(*t);
  } else {
    tips = tip_script("access", o.force_N, o.seconds);
  }
  auto device = SimulatedDevice::create(to_hand_script(tips, station), limits, hand);
  if (!device) {
    print_error("demo", device.error());
    return 1;
  }
  EngineConfig cfg;
  cfg.model = o.model;
  cfg.cut.sample_jitter = o.sample_jitter;
  if (o.overlap_cut) haptics::use_overlap_cut(cfg);
  cfg.T_tooth_dev = station.T_tooth_dev;
  cfg.T_sty_tip = station.T_sty_tip;
  // The header is written before the engine runs; a throwaway engine on the
  // same inputs produces it (the configuration, not the state, goes in it).
  std::string header;
  {
    auto probe = Engine::create(cfg, **device, vol, *bur, nullptr);
    if (!probe) {
      print_error("demo", probe.error());
      return 2;
    }
    header = (*probe)->header_json(tooth_desc.dump());
  }
  const std::string log_path = (fs::path(o.out) / "session.dlog").string();
  auto log = SessionLogWriter::open(log_path, header);
  if (!log) {
    print_error("demo", log.error());
    return 1;
  }
  auto engine = Engine::create(cfg, **device, vol, *bur, log->get());
  if (!engine) {
    print_error("demo", engine.error());
    return 2;
  }

  Surface surface(vol);
  const std::size_t tris0 = surface.extract_all();
  std::cout << "surface: " << tris0 << " triangles\n";
  const double script_s = (*device)->script_end_s();
  std::size_t remeshed = 0;
  const auto t0 = Clock::now();
  std::unique_ptr<sound::SoundPlayer> player;
  // The pulp-exposure event as it happens (the snapshot's flag), as the
  // display would show it.
  bool announced = false;
  auto announce = [&] {
    const HapticSnapshot snap = (*engine)->snapshot();
    if (snap.pulp_exposed && !announced) {
      announced = true;
      std::cout << "EVENT pulp exposure at t = " << snap.pulp_exposed_at_s << " s (seen by the display at "
                << snap.time_s << " s)\n"
                << std::flush;
    }
  };
  if (o.simulated) {
    for (std::uint64_t s = 0; s * 1e-3 < script_s; s += 33) {
      (*engine)->run_steps(33);
      remeshed += surface.update().size();
      announce();
    }
  } else {
    std::cout << "running " << script_s << " s of scripted drilling in real time (1 kHz thread)\n";
    if (Status st = (*engine)->start(); !st) {
      print_error("demo", st.error());
      return 1;
    }
    // The drill's sound reads the engine's snapshot on its own thread, as the display does.
    Engine* eng = engine->get();
    player = start_live_sound("demo", o.sound, [eng] { return eng->snapshot(); });
    // Display side: re-mesh dirty chunks at ~30 Hz while the haptic thread cuts.
    while ((*engine)->snapshot().time_s < script_s) {
      std::this_thread::sleep_for(std::chrono::milliseconds(33));
      remeshed += surface.update().size();
      announce();
    }
    if (player) player->stop();
    (*engine)->stop();
  }
  remeshed += surface.update().size();
  const double wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (Status st = (*log)->close(); !st) {
    print_error("demo", st.error());
    return 1;
  }

  const EngineStats s = (*engine)->stats();
  const CutMetrics m = (*engine)->cutter().metrics();
  print_metrics(m, (*engine)->snapshot().pulp_exposed_at_s);
  std::cout << std::setprecision(1) << "haptic steps: " << s.steps << " in " << wall_s
            << " s wall; step compute p50 " << s.compute.percentile_s(0.5) * 1e6 << " us, p99 "
            << s.compute.percentile_s(0.99) * 1e6 << " us, p99.9 "
            << s.compute.percentile_s(0.999) * 1e6 << " us, max " << s.compute.max_s() * 1e6
            << " us\n";
  if (!o.simulated) {
    std::cout << "period jitter p50 " << s.jitter.percentile_s(0.5) * 1e6 << " us, p99 "
              << s.jitter.percentile_s(0.99) * 1e6 << " us; missed deadlines "
              << s.missed_deadlines << ", watchdog trips " << s.watchdog_trips << "\n";
    std::cout << "real-time priority (SCHED_FIFO): "
              << (s.realtime_granted ? "granted" : "not granted — " + s.realtime_note) << "\n";
  }
  std::cout << "re-meshed " << remeshed << " chunks; log " << log_path << " ("
            << (*log)->written() << " records, " << s.log_dropped << " dropped)\n";

  const TriangleMesh mesh = merge_chunks(surface.chunks());
  const std::string ply = (fs::path(o.out) / "cut_tooth.ply").string();
  if (Status st = write_ply(mesh, ply); !st) {
    print_error("demo", st.error());
    return 1;
  }
  std::cout << "wrote " << ply << " (" << mesh.triangle_count() << " triangles)\n";
  if (o.obj) {
    const std::string obj = (fs::path(o.out) / "cut_tooth.obj").string();
    if (Status st = write_obj(mesh, obj); !st) {
      print_error("demo", st.error());
      return 1;
    }
  }

  // Replay the log on a fresh tooth in simulated time.
  const std::uint64_t live_hash = vol.content_hash();
  auto rec = read_session_log(log_path);
  if (!rec) {
    print_error("demo", rec.error());
    return 1;
  }
  if (!rec->warning.empty()) std::cout << "warning: " << rec->warning << "\n";
  auto fresh = training::make_tooth(tooth_desc.dump());
  if (!fresh) {
    print_error("demo", fresh.error());
    return 1;
  }
  const auto r0 = Clock::now();
  auto rep = replay_session(*rec, *fresh);
  const double rep_s = std::chrono::duration<double>(Clock::now() - r0).count();
  if (!rep) {
    print_error("demo", rep.error());
    return 1;
  }
  const bool match = rep->volume_hash == live_hash;
  std::cout << "volume hash: start " << hex(start_hash) << ", live " << hex(live_hash)
            << ", replay " << hex(rep->volume_hash) << (match ? "  (match)" : "  (MISMATCH)")
            << "\n";
  std::cout << std::setprecision(2) << "replay: " << rep->steps << " steps in " << rep_s << " s ("
            << rep->steps * 1e-3 / std::max(rep_s, 1e-9) << "x real time), max force difference "
            << rep->max_force_difference_N << " N\n";
  if (!o.sound.audio.empty())
    if (int rc = render_session_wav("demo", log_path, o.sound.audio, o.sound, false); rc != 0) return 1;
  if (!o.no_score) {
    // Scored against the exercise drilled (without --exercise: the molar's
    // occlusal access, as the molar access opening). A failure to score is a
    // warning; the session and the hash check stand.
    session::DriverScoreInput in;
    in.session = log_path;
    in.out_dir = o.out;
    in.exercise = o.exercise;
    const session::DriverScore d = session::score_after_run(in);
    if (d.ok)
      std::cout << d.line << "\n";
    else
      std::cout << "warning: " << d.warning << "\n";
  }
  return match ? 0 : 1;
}

}  // namespace

void add_demo(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* c = app.add_subcommand(
      "demo",
      "Drill the built-in molar, or the tooth of --exercise, through the 1 kHz haptic engine\n"
      "(simulated hand, scripted pedal), write the session log and the cut mesh, replay the log and check the hash;\n"
      "then score the session (score.json, score.html; see dentar score).\n"
      "Synopsis: dentar demo [--model proxy|seed] [--bur SHAPE] [--samples N] [--seconds S]\n"
      "                      [--simulated] [--out DIR] [--exercise NAME|FILE] [--no-score] [--no-sample-jitter]\n"
      "                      [--audio FILE.wav] [--audio-device NAME] [--volume PCT] [--mute]\n"
      "                      [--drill-sample FILE]\n"
      "In real time (not --simulated) the drill's sound plays through the audio device while the\n"
      "engine runs (no device: a warning, the demo runs silent); --audio renders it to a WAV file.");
  c->add_option("--voxel-mm", o->voxel_mm, "Voxel size of the procedural molar (mm)")
      ->check(CLI::Range(0.02, 0.5))
      ->capture_default_str();
  c->add_option("--bur", o->bur, "Bur shape: sphere, cylinder, capsule, cone (default: the exercise's bur with --exercise)")
      ->check(CLI::IsMember({"sphere", "cylinder", "capsule", "cone"}))
      ->capture_default_str();
  c->add_option("--bur-radius-mm", o->bur_radius_mm, "Bur radius (mm)")
      ->check(CLI::Range(0.05, 5.0))
      ->capture_default_str();
  c->add_option("--bur-length-mm", o->bur_length_mm, "Bur working length (mm)")
      ->check(CLI::Range(0.1, 30.0))
      ->capture_default_str();
  c->add_option("--samples", o->samples, "Volumetric bur samples (1000..30000)")
      ->check(CLI::Range(1000, 30000))
      ->capture_default_str();
  c->add_option("--model", o->model, "Force model: proxy (ours) or seed (the 2012 model)")
      ->check(CLI::IsMember({"proxy", "seed"}))
      ->capture_default_str();
  c->add_option("--force", o->force_N, "Pressing force the molar's scripted hand asks for (N; not with --exercise)")
      ->check(CLI::Range(0.1, 3.0))
      ->capture_default_str();
  c->add_option("--seconds", o->seconds, "Length of the molar's drilling passes (s); 0 = default 12 s (not with --exercise)")
      ->check(CLI::Range(0.0, 600.0))
      ->capture_default_str();
  c->add_flag("--simulated", o->simulated, "Run in simulated time (as fast as possible)");
  c->add_option("--out", o->out, "Output folder")->capture_default_str();
  c->add_flag("--obj", o->obj, "Also write cut_tooth.obj");
  c->add_option("--exercise", o->exercise,
                "Exercise drilled and scored: its tooth, its bur and an expert pass through its steps\n"
                "(default: the molar's scripted access, scored as molar_access_opening)");
  c->add_flag("--sample-jitter,!--no-sample-jitter", o->sample_jitter,
             "Shift the bur's samples by a sub-spacing offset each step, the default (the cut rate then no "
             "longer depends on the voxel size; docs/BENCHMARKS.md, haptics sessions 20 and 21); "
             "--no-sample-jitter cuts with the fixed samples, as sessions before session 21");
  c->add_flag("--overlap-cut,!--no-overlap-cut", o->overlap_cut,
             "Cut by the bur's overlap with each voxel and constrain the proxy with the bur's shape, the "
             "default (the cut rate does not depend on --samples; docs/BENCHMARKS.md, haptics session 22); "
             "--no-overlap-cut cuts with the bur's samples, as sessions before session 22");
  c->add_flag("--no-score", o->no_score, "Do not score the session (score.json, score.html)");
  c->add_option("--audio", o->sound.audio, "Also render the session's drill sound to this WAV file (docs/sound.md)");
  add_sound_options(c, o->sound, true);
  c->footer("Example:\n  dentar demo --model proxy --bur capsule --samples 10000 --out out/demo\n"
            "  dentar demo --simulated --out out/demo --audio out/demo/drill.wav");
  c->callback([o, c, &exit_code] {
    if (std::string e = session::check_exercise(o->exercise); !e.empty()) {
      print_error("demo", e);
      exit_code = 2;
      return;
    }
    o->sound.exercise = o->exercise;  // --teach-force-limit exercise
    o->bur_given = c->count("--bur") > 0;
    if (!o->exercise.empty() && (c->count("--force") > 0 || c->count("--seconds") > 0)) {
      print_error("demo", "--force and --seconds shape the molar's scripted pass; with --exercise the simulated "
                          "hand follows the exercise's own steps: leave them out");
      exit_code = 2;
      return;
    }
    if (auto p = drill_params_from(o->sound); !p) {  // a user sample that is not audio: bad input
      print_error("demo", p.error());
      exit_code = 2;
      return;
    }
    exit_code = run_demo(*o);
  });
}

}  // namespace dentar::tools
