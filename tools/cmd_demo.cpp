// dentar demo: the volume demo. Builds the default procedural molar, drives a
// scripted sequence of bur strokes through the cutter at 1 kHz simulated
// time, re-meshes dirty chunks at 30 Hz as the display would, writes the cut
// mesh (PLY) and prints the removed volume per material.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <vector>

#include "commands.h"
#include "dentar/volume/cutter.h"
#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"

namespace dentar::tools {
namespace {

using namespace dentar::volume;
using Clock = std::chrono::steady_clock;

struct DemoOptions {
  double voxel_mm = 0.08;
  std::string bur = "capsule";
  double bur_radius_mm = 0.5;
  double bur_length_mm = 3.0;
  int samples = 10000;
  double force_N = 2.0;
  std::string out = "out/demo";
  bool obj = false;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// Scripted strokes of an occlusal access preparation (tooth frame, metres):
// passes along the central groove, each 0.5 mm deeper, then a plunge toward
// the chamber roof that exposes the pulp (what an instructor wants flagged).
struct Stroke {
  Eigen::Vector3d from, to;
  double seconds;
};
std::vector<Stroke> script() {
  std::vector<Stroke> s;
  double z = 6.6e-3;
  for (int pass = 0; pass < 6; ++pass, z -= 0.5e-3) {
    const double x0 = pass % 2 ? 2.2e-3 : -2.2e-3;
    s.push_back({{x0, 0.3e-3, z}, {-x0, 0.3e-3, z}, 1.0});
    s.push_back({{-x0, -0.3e-3, z}, {x0, -0.3e-3, z}, 1.0});
  }
  s.push_back({{0, 0, z}, {0, 0, 2.6e-3}, 1.5});
  return s;
}

int run_demo(const DemoOptions& o) {
  namespace fs = std::filesystem;
  MolarParams mp;
  mp.voxel_mm = o.voxel_mm;
  const auto t0 = Clock::now();
  auto tooth = make_molar(mp);
  if (!tooth) {
    print_error("demo", tooth.error());
    return 2;
  }
  VoxelVolume& vol = *tooth;
  auto shape = parse_bur_shape(o.bur);
  if (!shape) {
    print_error("demo", "--bur: " + shape.error());
    return 2;
  }
  BurParams bp = BurParams::cylinder(o.bur_radius_mm, o.bur_length_mm);
  bp.shape = *shape;
  if (*shape == BurShape::kSphere) bp = BurParams::sphere(o.bur_radius_mm);
  if (*shape == BurShape::kCone) bp = BurParams::cone(0.5 * o.bur_radius_mm, o.bur_radius_mm, o.bur_length_mm);
  auto bur = sample_bur(bp, o.samples);
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
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::cout << "tooth: procedural maxillary molar, " << vol.dims().x() << "x" << vol.dims().y()
            << "x" << vol.dims().z() << " voxels of " << o.voxel_mm << " mm, "
            << vol.allocated_chunks() << "/" << vol.num_chunks() << " chunks allocated ("
            << vol.memory_bytes() / 1000000.0 << " MB vs " << vol.dense_bytes() / 1000000.0
            << " MB dense), built in " << build_s << " s\n";
  std::cout << "bur: " << bur_shape_name(bp.shape) << " r=" << bp.radius_m * 1e3
            << " mm L=" << bp.length_m * 1e3 << " mm, " << bur->size() << " samples\n";

  Surface surface(vol);
  auto t1 = Clock::now();
  const std::size_t tris0 = surface.extract_all();
  const double full_ms = std::chrono::duration<double, std::milli>(Clock::now() - t1).count();
  std::cout << "surface: " << tris0 << " triangles, full extraction " << full_ms << " ms\n";

  Cutter cutter(vol);
  std::vector<double> cut_us, mesh_ms;
  std::size_t chunks_remeshed = 0;
  std::uint64_t step = 0;
  bool announced = false;
  Eigen::Isometry3d T_tooth_tip = Eigen::Isometry3d::Identity();
  // Bur pointing down into the occlusal surface (tip +z = tooth -z).
  T_tooth_tip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (const Stroke& s : script()) {
    const int n = static_cast<int>(std::lround(s.seconds * 1000));
    for (int i = 0; i < n; ++i, ++step) {
      T_tooth_tip.translation() = s.from + (s.to - s.from) * (static_cast<double>(i) / n);
      const auto c0 = Clock::now();
      const CutResult r = cutter.step(*bur, T_tooth_tip, o.force_N, 1e-3);
      cut_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - c0).count());
      if (r.touched_pulp && !announced) {
        announced = true;
        std::cout << "EVENT pulp exposure at t=" << step / 1000.0 << " s\n";
      }
      if (step % 33 == 0) {  // ~30 Hz display: re-mesh dirty chunks only
        const auto m0 = Clock::now();
        chunks_remeshed += surface.update().size();
        mesh_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - m0).count());
      }
    }
  }
  chunks_remeshed += surface.update().size();

  const CutMetrics m = cutter.metrics();
  std::cout << std::fixed << std::setprecision(3);
  std::cout << "strokes: " << script().size() << ", " << step << " steps at 1 kHz ("
            << step / 1000.0 << " s simulated)\n";
  std::cout << "removed volume per material (mm^3):\n";
  for (int mat = 1; mat < kNumMaterials; ++mat)
    std::cout << "  " << std::setw(12) << std::left << material_name(static_cast<Material>(mat))
              << std::right << std::setw(10) << m.removed_mm3[static_cast<std::size_t>(mat)] << "\n";
  std::cout << "  " << std::setw(12) << std::left << "total" << std::right << std::setw(10)
            << m.removed_total_mm3 << "  (" << m.removed_percent << " % of "
            << m.original_tooth_mm3 << " mm^3)\n";
  if (m.pulp_exposure)
    std::cout << "pulp exposed at step " << m.pulp_exposure->step << ", tooth-frame position ("
              << m.pulp_exposure->position_m.x() * 1e3 << ", " << m.pulp_exposure->position_m.y() * 1e3
              << ", " << m.pulp_exposure->position_m.z() * 1e3 << ") mm\n";
  else
    std::cout << "pulp not exposed\n";
  std::cout << "cut step: p50 " << percentile(cut_us, 0.5) << " us, p99 " << percentile(cut_us, 0.99)
            << " us; re-mesh per display frame: p50 " << percentile(mesh_ms, 0.5) << " ms, p99 "
            << percentile(mesh_ms, 0.99) << " ms (" << chunks_remeshed << " chunk re-meshes)\n";
  std::cout << "volume hash: " << std::hex << vol.content_hash() << std::dec << "\n";

  const TriangleMesh mesh = merge_chunks(surface.chunks());
  const std::string ply = (fs::path(o.out) / "cut_tooth.ply").string();
  if (Status st = write_ply(mesh, ply); !st) {
    print_error("demo", st.error());
    return 1;
  }
  std::cout << "wrote " << ply << " (" << mesh.triangle_count() << " triangles, "
            << mesh.vertices.size() << " vertices)\n";
  if (o.obj) {
    const std::string obj = (fs::path(o.out) / "cut_tooth.obj").string();
    if (Status st = write_obj(mesh, obj); !st) {
      print_error("demo", st.error());
      return 1;
    }
    std::cout << "wrote " << obj << "\n";
  }
  return 0;
}

}  // namespace

void add_demo(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* c = app.add_subcommand(
      "demo",
      "Cut the built-in molar with a scripted sequence of bur strokes; write the cut mesh\n"
      "as PLY and print the removed volume per material.\n"
      "Synopsis: dentar demo [--voxel-mm MM] [--bur SHAPE] [--samples N] [--out DIR]");
  c->add_option("--voxel-mm", o->voxel_mm, "Voxel size of the procedural molar (mm)")
      ->check(CLI::Range(0.02, 0.5))
      ->capture_default_str();
  c->add_option("--bur", o->bur, "Bur shape: sphere, cylinder, capsule, cone")
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
  c->add_option("--force", o->force_N, "Pressing force during the strokes (N)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  c->add_option("--out", o->out, "Output folder")->capture_default_str();
  c->add_flag("--obj", o->obj, "Also write cut_tooth.obj");
  c->footer("Example:\n  dentar demo --voxel-mm 0.08 --bur capsule --samples 10000 --out out/demo");
  c->callback([o, &exit_code] { exit_code = run_demo(*o); });
}

}  // namespace dentar::tools
