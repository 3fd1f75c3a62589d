// dentar tooth: build the procedural molar and export its surface (and,
// optionally, its density and label volumes for other tools).
#include <iostream>

#include "commands.h"
#include "dentar/volume/image_volume.h"
#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"

namespace dentar::tools {
namespace {

using namespace dentar::volume;

struct ToothOptions {
  MolarParams params;
  std::string ply = "out/tooth.ply";
  std::string obj;
  std::string density_json;
  std::string labels_json;
};

// Dense copy of one channel of the voxel volume, for the raw+JSON writer.
ImageVolume channel(const VoxelVolume& v, bool labels) {
  ImageVolume img;
  img.geometry = v.geometry();
  img.source_type = ElementType::kUInt8;
  img.values.resize(static_cast<std::size_t>(v.geometry().voxel_count()));
  std::size_t n = 0;
  for (int k = 0; k < v.dims().z(); ++k)
    for (int j = 0; j < v.dims().y(); ++j)
      for (int i = 0; i < v.dims().x(); ++i)
        img.values[n++] = labels ? static_cast<float>(v.material(i, j, k)) : v.density(i, j, k);
  return img;
}

int run_tooth(const ToothOptions& o) {
  auto tooth = make_molar(o.params);
  if (!tooth) {
    print_error("tooth", tooth.error());
    return 2;
  }
  Surface s(*tooth);
  s.extract_all();
  const TriangleMesh mesh = merge_chunks(s.chunks());
  std::cout << "molar: " << tooth->dims().x() << "x" << tooth->dims().y() << "x"
            << tooth->dims().z() << " voxels of " << o.params.voxel_mm << " mm, "
            << mesh.triangle_count() << " triangles, hash " << std::hex << tooth->content_hash()
            << std::dec << "\n";
  if (Status st = write_ply(mesh, o.ply); !st) {
    print_error("tooth", st.error());
    return 1;
  }
  std::cout << "wrote " << o.ply << "\n";
  if (!o.obj.empty()) {
    if (Status st = write_obj(mesh, o.obj); !st) {
      print_error("tooth", st.error());
      return 1;
    }
    std::cout << "wrote " << o.obj << "\n";
  }
  for (const auto& [path, labels] : {std::pair{o.density_json, false}, {o.labels_json, true}}) {
    if (path.empty()) continue;
    if (Status st = write_raw_json(channel(*tooth, labels), path); !st) {
      print_error("tooth", st.error());
      return 1;
    }
    std::cout << "wrote " << path << "\n";
  }
  return 0;
}

}  // namespace

void add_tooth(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<ToothOptions>();
  CLI::App* c = app.add_subcommand(
      "tooth",
      "Build the procedural molar and export its surface mesh (mm).\n"
      "Synopsis: dentar tooth [--voxel-mm MM] [--ply FILE] [--obj FILE] [--density FILE.json]");
  auto& p = o->params;
  c->add_option("--voxel-mm", p.voxel_mm, "Voxel size (mm)")->check(CLI::Range(0.02, 0.5))
      ->capture_default_str();
  c->add_option("--crown-md-mm", p.crown_mesiodistal_mm, "Crown mesio-distal width (mm)")
      ->capture_default_str();
  c->add_option("--crown-bl-mm", p.crown_buccolingual_mm, "Crown bucco-lingual width (mm)")
      ->capture_default_str();
  c->add_option("--enamel-mm", p.enamel_mm, "Occlusal enamel thickness (mm)")->capture_default_str();
  c->add_option("--root-mm", p.root_length_mm, "Root length (mm)")->capture_default_str();
  c->add_option("--ply", o->ply, "Output PLY mesh")->capture_default_str();
  c->add_option("--obj", o->obj, "Also write an OBJ mesh");
  c->add_option("--density", o->density_json, "Also write the density volume (raw + JSON sidecar)");
  c->add_option("--labels", o->labels_json, "Also write the material labels (raw + JSON sidecar)");
  c->footer("Example:\n  dentar tooth --voxel-mm 0.1 --ply out/tooth.ply --density out/tooth.json");
  c->callback([o, &exit_code] { exit_code = run_tooth(*o); });
}

}  // namespace dentar::tools
