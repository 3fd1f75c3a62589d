// Surface extraction benchmarks on the procedural molar scaled into a 256^3
// volume (longest axis ~240 voxels), single thread:
//   BM_ExtractAll          full extraction (triangles reported as a counter)
//   BM_VtkFlyingEdges3D    vtkFlyingEdges3D on the same densities and iso
//                          (only with DENTAR_HAVE_VTK; sequential SMP backend)
//   BM_RatioVsVtk          both, interleaved per iteration; ratio of medians
//   BM_RemeshDirtyChunk    mark one surface chunk dirty + Surface::update(),
//                          cycling over all surface chunks; p50/p99 counters
//                          from per-iteration timings
//   BM_ExtractOneChunk     SurfaceExtractor::extract_chunk alone, same chunks
//   BM_MergeChunks         merge_chunks over the whole surface
// Suggested run:
//   volume_surface_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "dentar/volume/procedural_tooth.h"
#include "dentar/volume/surface.h"

#ifdef DENTAR_HAVE_VTK
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>
#endif

namespace dv = dentar::volume;

namespace {

constexpr int kDim = 256;
constexpr int kTargetLongestVoxels = 240;

// The molar at a voxel size that makes its longest axis ~240 voxels, copied
// into the centre of a 256^3 volume.
const dv::VoxelVolume& tooth_256() {
  static const std::unique_ptr<dv::VoxelVolume> vol = [] {
    dv::MolarParams p;
    p.voxel_mm = 0.1;
    auto probe = dv::make_molar(p);
    if (!probe.ok()) {
      std::fprintf(stderr, "make_molar: %s\n", probe.error().c_str());
      std::exit(1);
    }
    const int longest0 = probe->dims().maxCoeff();
    p.voxel_mm = 0.1 * longest0 / kTargetLongestVoxels;
    auto tooth = dv::make_molar(p);
    while (tooth.ok() && tooth->dims().maxCoeff() > kTargetLongestVoxels) {
      p.voxel_mm *= 1.01;
      tooth = dv::make_molar(p);
    }
    if (!tooth.ok()) {
      std::fprintf(stderr, "make_molar: %s\n", tooth.error().c_str());
      std::exit(1);
    }
    const dv::VoxelVolume& src = tooth.value();
    dv::VolumeGeometry g = src.geometry();
    const Eigen::Vector3i off = (Eigen::Vector3i::Constant(kDim) - src.dims()) / 2;
    g.dims = Eigen::Vector3i::Constant(kDim);
    g.origin = src.origin() - src.spacing().cwiseProduct(off.cast<double>());
    auto out = std::make_unique<dv::VoxelVolume>(g);
    for (int k = 0; k < src.dims().z(); ++k)
      for (int j = 0; j < src.dims().y(); ++j)
        for (int i = 0; i < src.dims().x(); ++i) {
          const std::uint8_t d = src.density(i, j, k);
          const dv::Material m = src.material(i, j, k);
          if (d != 0 || m != dv::Material::kAir)
            out->set(i + off.x(), j + off.y(), k + off.z(), d, m);
        }
    std::fprintf(stderr,
                 "tooth: voxel %.4f mm, tooth dims %dx%dx%d in %d^3, %d/%d chunks allocated\n",
                 p.voxel_mm, src.dims().x(), src.dims().y(), src.dims().z(), kDim,
                 out->allocated_chunks(), out->num_chunks());
    return out;
  }();
  return *vol;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void BM_ExtractAll(benchmark::State& state) {
  const dv::VoxelVolume& vol = tooth_256();
  dv::Surface s(vol);
  s.extract_all();  // grow the per-chunk vectors once, as a running app would
  std::size_t tris = 0;
  for (auto _ : state) {
    tris = s.extract_all();
    benchmark::DoNotOptimize(tris);
  }
  state.counters["triangles"] = static_cast<double>(tris);
  state.counters["vertices"] = static_cast<double>(s.vertex_count());
}
BENCHMARK(BM_ExtractAll)->Unit(benchmark::kMillisecond)->UseRealTime();

// Surface chunks of the tooth (non-empty meshes).
std::vector<int> surface_chunks(const dv::Surface& s) {
  std::vector<int> ids;
  for (std::size_t c = 0; c < s.chunks().size(); ++c)
    if (!s.chunks()[c].empty()) ids.push_back(static_cast<int>(c));
  return ids;
}

void BM_RemeshDirtyChunk(benchmark::State& state) {
  // The bench owns a copy so that marking chunks dirty touches nobody else.
  static dv::VoxelVolume vol = tooth_256().clone();
  dv::Surface s(vol);
  s.extract_all();
  const std::vector<int> ids = surface_chunks(s);
  std::vector<double> times_us;
  times_us.reserve(1 << 20);
  std::size_t next = 0, tris = 0;
  for (auto _ : state) {
    const int id = ids[next];
    next = next + 1 == ids.size() ? 0 : next + 1;
    const double t0 = now_s();
    vol.mark_dirty(id);
    auto changed = s.update();
    benchmark::DoNotOptimize(changed);
    times_us.push_back((now_s() - t0) * 1e6);
    tris += s.chunks()[static_cast<std::size_t>(id)].triangle_count();
  }
  state.counters["p50_us"] = percentile(times_us, 0.5);
  state.counters["p99_us"] = percentile(times_us, 0.99);
  state.counters["tris_per_chunk"] =
      static_cast<double>(tris) / static_cast<double>(std::max<std::size_t>(times_us.size(), 1));
  state.counters["surface_chunks"] = static_cast<double>(ids.size());
}
BENCHMARK(BM_RemeshDirtyChunk)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_ExtractOneChunk(benchmark::State& state) {
  const dv::VoxelVolume& vol = tooth_256();
  dv::Surface s(vol);
  s.extract_all();
  const std::vector<int> ids = surface_chunks(s);
  dv::SurfaceExtractor ex;
  dv::ChunkMesh mesh;
  std::vector<double> times_us;
  times_us.reserve(1 << 20);
  std::size_t next = 0;
  for (auto _ : state) {
    const int id = ids[next];
    next = next + 1 == ids.size() ? 0 : next + 1;
    const double t0 = now_s();
    ex.extract_chunk(vol, id, mesh);
    benchmark::DoNotOptimize(mesh.indices.data());
    times_us.push_back((now_s() - t0) * 1e6);
  }
  state.counters["p50_us"] = percentile(times_us, 0.5);
  state.counters["p99_us"] = percentile(times_us, 0.99);
}
BENCHMARK(BM_ExtractOneChunk)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_MergeChunks(benchmark::State& state) {
  const dv::VoxelVolume& vol = tooth_256();
  dv::Surface s(vol);
  s.extract_all();
  std::size_t verts = 0;
  for (auto _ : state) {
    dv::TriangleMesh m = dv::merge_chunks(s.chunks());
    verts = m.vertices.size();
    benchmark::DoNotOptimize(m.indices.data());
  }
  state.counters["merged_vertices"] = static_cast<double>(verts);
  state.counters["chunk_vertices"] = static_cast<double>(s.vertex_count());
}
BENCHMARK(BM_MergeChunks)->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef DENTAR_HAVE_VTK
// The same densities as a 256^3 vtkImageData (x fastest, as VTK expects).
vtkImageData* vtk_tooth() {
  static vtkNew<vtkImageData> img;
  static bool made = false;
  if (!made) {
    const dv::VoxelVolume& vol = tooth_256();
    img->SetDimensions(kDim, kDim, kDim);
    img->SetSpacing(vol.spacing().data());
    img->SetOrigin(vol.origin().data());
    vtkNew<vtkUnsignedCharArray> a;
    a->SetName("density");
    a->SetNumberOfTuples(vtkIdType{kDim} * kDim * kDim);
    std::uint8_t* p = a->GetPointer(0);
    for (int k = 0; k < kDim; ++k)
      for (int j = 0; j < kDim; ++j)
        for (int i = 0; i < kDim; ++i) *p++ = vol.density(i, j, k);
    img->GetPointData()->SetScalars(a);
    made = true;
  }
  return img;
}

// Normals on (we compute them too), no gradients or scalars; VTK's SMP
// backend is forced to Sequential with one thread in main().
void configure(vtkFlyingEdges3D* fe) {
  fe->SetInputData(vtk_tooth());
  fe->SetValue(0, dv::kIsoDensity);
  fe->ComputeNormalsOn();
  fe->ComputeGradientsOff();
  fe->ComputeScalarsOff();
  fe->InterpolateAttributesOff();
}

void BM_VtkFlyingEdges3D(benchmark::State& state) {
  vtkNew<vtkFlyingEdges3D> fe;
  configure(fe);
  fe->Update();
  for (auto _ : state) {
    fe->Modified();
    fe->Update();
    benchmark::DoNotOptimize(fe->GetOutput()->GetNumberOfPolys());
  }
  state.counters["triangles"] = static_cast<double>(fe->GetOutput()->GetNumberOfPolys());
}
BENCHMARK(BM_VtkFlyingEdges3D)->Unit(benchmark::kMillisecond)->UseRealTime();

// Ours and VTK alternately in every iteration, so machine-load drift hits
// both; reports the ratio of the medians.
void BM_RatioVsVtk(benchmark::State& state) {
  const dv::VoxelVolume& vol = tooth_256();
  dv::Surface s(vol);
  s.extract_all();
  vtkNew<vtkFlyingEdges3D> fe;
  configure(fe);
  fe->Update();
  std::vector<double> ours_ms, vtk_ms;
  for (auto _ : state) {
    double t0 = now_s();
    benchmark::DoNotOptimize(s.extract_all());
    ours_ms.push_back((now_s() - t0) * 1e3);
    t0 = now_s();
    fe->Modified();
    fe->Update();
    vtk_ms.push_back((now_s() - t0) * 1e3);
  }
  const double a = percentile(ours_ms, 0.5), b = percentile(vtk_ms, 0.5);
  state.counters["ours_p50_ms"] = a;
  state.counters["vtk_p50_ms"] = b;
  state.counters["ratio_p50"] = b > 0 ? a / b : 0.0;
  state.counters["ours_triangles"] = static_cast<double>(s.triangle_count());
  state.counters["vtk_triangles"] = static_cast<double>(fe->GetOutput()->GetNumberOfPolys());
}
BENCHMARK(BM_RatioVsVtk)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
#endif

}  // namespace

int main(int argc, char** argv) {
#ifdef DENTAR_HAVE_VTK
  // One thread for a fair single-threaded comparison: VTK reads these when
  // its SMP layer first starts. (vtkSMPTools.h of VTK 9.1 does not compile
  // as C++20, so the environment is the way in here.)
  setenv("VTK_SMP_BACKEND_IN_USE", "Sequential", 1);
  setenv("VTK_SMP_MAX_THREADS", "1", 1);
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
