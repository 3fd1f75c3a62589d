// dentar ct: load a CT volume (raw+JSON, MetaImage, NRRD), segment it into
// enamel / dentin / pulp by thresholds (automatic multi-level Otsu unless
// given) and export the tooth surface.
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.h"
#include "dentar/volume/image_volume.h"
#include "dentar/volume/surface.h"

namespace dentar::tools {
namespace {

using namespace dentar::volume;

struct CtOptions {
  std::string input;
  std::vector<float> thresholds;
  std::string ply;
};

int run_ct(const CtOptions& o) {
  auto img = load_volume(o.input);
  if (!img) {
    print_error("ct", img.error());
    return 2;
  }
  Thresholds t;
  if (o.thresholds.empty()) {
    auto a = auto_thresholds(*img);
    if (!a) {
      print_error("ct", a.error() + " (give --thresholds DARK,TOOTH,ENAMEL)");
      return 1;
    }
    t = *a;
  } else {
    if (o.thresholds.size() != 3) {
      print_error("ct", "--thresholds needs 3 values DARK_MAX,TOOTH_MIN,ENAMEL_MIN, got " +
                            std::to_string(o.thresholds.size()));
      return 2;
    }
    t = {o.thresholds[0], o.thresholds[1], o.thresholds[2]};
    if (std::string why = t.validate(); !why.empty()) {
      print_error("ct", "--thresholds: " + why);
      return 2;
    }
  }
  SegmentationReport rep;
  auto vol = segment_ct(*img, t, &rep);
  if (!vol) {
    print_error("ct", vol.error());
    return 1;
  }
  const auto& g = img->geometry;
  std::cout << o.input << ": " << g.dims.x() << "x" << g.dims.y() << "x" << g.dims.z() << " "
            << element_type_name(img->source_type) << ", spacing " << g.spacing.x() * 1e3 << " x "
            << g.spacing.y() * 1e3 << " x " << g.spacing.z() * 1e3 << " mm\n";
  std::cout << "thresholds (" << (o.thresholds.empty() ? "automatic" : "given")
            << "): dark < " << rep.thresholds.dark_max << ", tooth >= " << rep.thresholds.tooth_min
            << ", enamel >= " << rep.thresholds.enamel_min << "\n";
  const double voxel_mm3 = g.spacing.prod() * 1e9;
  for (int m = 0; m < kNumMaterials; ++m) {
    const auto n = rep.voxels[static_cast<std::size_t>(m)];
    if (n == 0 && m > 3) continue;
    std::cout << "  " << std::setw(12) << std::left << material_name(static_cast<Material>(m))
              << std::right << std::setw(10) << n << " voxels " << std::setw(10) << std::fixed
              << std::setprecision(2) << n * voxel_mm3 << " mm^3\n";
  }
  if (!o.ply.empty()) {
    Surface s(*vol);
    s.extract_all();
    const TriangleMesh mesh = merge_chunks(s.chunks());
    if (Status st = write_ply(mesh, o.ply); !st) {
      print_error("ct", st.error());
      return 1;
    }
    std::cout << "wrote " << o.ply << " (" << mesh.triangle_count() << " triangles)\n";
  }
  return 0;
}

}  // namespace

void add_ct(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<CtOptions>();
  CLI::App* c = app.add_subcommand(
      "ct",
      "Load a CT volume, segment enamel/dentin/pulp and export the tooth surface.\n"
      "Synopsis: dentar ct --input FILE(.json|.mhd|.mha|.nrrd|.nhdr) [--thresholds A,B,C] [--ply FILE]");
  c->add_option("--input", o->input, "Volume file; .json is a raw+JSON sidecar (docs/formats.md)")
      ->required();
  c->add_option("--thresholds", o->thresholds,
                "DARK_MAX,TOOTH_MIN,ENAMEL_MIN in file intensity units (default: automatic)")
      ->delimiter(',');
  c->add_option("--ply", o->ply, "Write the segmented tooth surface as PLY (mm)");
  c->footer("Example:\n  dentar ct --input ../shared/data/tooth.json --ply out/ct_tooth.ply");
  c->callback([o, &exit_code] { exit_code = run_ct(*o); });
}

}  // namespace dentar::tools
