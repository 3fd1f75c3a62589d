// Otsu thresholds, automatic dental thresholds and CT segmentation, on
// synthetic phantoms and on the real tooth CT in ../shared/data.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "dentar/volume/image_volume.h"
#include "testutil.h"

namespace dentar::volume {
namespace {

namespace fs = std::filesystem;

// A phantom tooth: noisy background ~80, a box of dentin ~160 with an enamel
// cap ~230 on top (low z), a dark pulp ~30 inside, and optionally a dark canal
// from the pulp through the dentin to the far (high z) border, like a root cut
// by the field of view.
ImageVolume phantom(bool open_canal) {
  ImageVolume v;
  v.geometry.dims = {56, 40, 48};  // x beyond the tooth: empty chunks
  v.values.resize(static_cast<std::size_t>(v.geometry.voxel_count()));
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 3.f);
  for (int k = 0; k < 48; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 56; ++i) {
        float x = 80;
        const bool in_tooth = i >= 8 && i < 32 && j >= 8 && j < 32 && k >= 6 && k < 44;
        if (in_tooth) x = k < 12 || i < 10 || i >= 30 || j < 10 || j >= 30 ? 230 : 160;
        if (i >= 16 && i < 24 && j >= 16 && j < 24 && k >= 18 && k < 30) x = 30;
        if (open_canal && i >= 19 && i < 21 && j >= 19 && j < 21 && k >= 18) x = 30;
        v.values[v.index(i, j, k)] = std::clamp(x + noise(rng), 0.f, 255.f);
      }
  return v;
}

TEST(Otsu, SeparatesThreeClasses) {
  ImageVolume v;
  v.geometry.dims = {30, 1, 1};
  for (int i = 0; i < 30; ++i) v.values.push_back(i < 10 ? 10.f : i < 20 ? 100.f : 200.f);
  const auto t = multi_otsu(v, 2);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_GT(t[0], 10.f);
  EXPECT_LE(t[0], 100.f);
  EXPECT_GT(t[1], 100.f);
  EXPECT_LE(t[1], 200.f);
  // Constant image: all thresholds equal the value.
  ImageVolume c;
  c.geometry.dims = {2, 1, 1};
  c.values = {5, 5};
  EXPECT_EQ(multi_otsu(c, 3), (std::vector<float>{5, 5, 5}));
  EXPECT_FALSE(auto_thresholds(c).ok());
}

TEST(Thresholds, Validate) {
  Thresholds t{40, 120, 200, 80};
  EXPECT_EQ(t.validate(), "");
  t.enamel_min = 100;
  EXPECT_NE(t.validate().find("enamel_min"), std::string::npos);
  t = {40, 120, 200, 130};
  EXPECT_NE(t.validate().find("background"), std::string::npos);
  t = {NAN, 120, 200, 80};
  EXPECT_NE(t.validate().find("finite"), std::string::npos);
  EXPECT_FALSE(segment_ct(phantom(false), t).ok());
}

TEST(Segmentation, PhantomWithEnclosedPulp) {
  const ImageVolume v = phantom(false);
  auto t = auto_thresholds(v);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_GT(t->dark_max, 35.f);
  EXPECT_LT(t->dark_max, 75.f);
  EXPECT_GT(t->tooth_min, 90.f);
  EXPECT_LT(t->tooth_min, 150.f);
  EXPECT_GT(t->enamel_min, 170.f);
  EXPECT_LT(t->enamel_min, 220.f);
  SegmentationReport rep;
  auto vol = segment_ct(v, *t, &rep);
  ASSERT_TRUE(vol.ok()) << vol.error();
  EXPECT_EQ(vol->material(20, 20, 24), Material::kPulp);
  EXPECT_EQ(vol->material(20, 20, 8), Material::kEnamel);
  EXPECT_EQ(vol->material(20, 20, 15), Material::kDentin);
  EXPECT_EQ(vol->material(2, 2, 2), Material::kAir);
  EXPECT_EQ(rep.voxels[static_cast<std::size_t>(Material::kPulp)], 8 * 8 * 12);
  // Tooth is solid, air/pulp below the iso level; far air is unallocated.
  EXPECT_GT(vol->density(20, 20, 15), kIsoDensity);
  EXPECT_LT(vol->density(20, 20, 24), kIsoDensity);
  EXPECT_EQ(vol->density(2, 2, 2), 0);
  EXPECT_EQ(vol->chunk(vol->chunk_id(3, 0, 0)), nullptr);
  EXPECT_LT(vol->allocated_chunks(), vol->num_chunks());
  std::int64_t total = 0;
  for (auto c : rep.voxels) total += c;
  EXPECT_EQ(total, v.geometry.voxel_count());
}

TEST(Segmentation, OpenCanalStaysPulp) {
  const ImageVolume v = phantom(true);
  auto t = auto_thresholds(v);
  ASSERT_TRUE(t.ok()) << t.error();
  SegmentationReport rep;
  auto vol = segment_ct(v, *t, &rep);
  ASSERT_TRUE(vol.ok()) << vol.error();
  // The chamber and the canal inside the root are pulp although connected to
  // the border; the bit of canal beyond the tooth (k >= 44) is outside it.
  EXPECT_EQ(vol->material(20, 20, 24), Material::kPulp);
  EXPECT_EQ(vol->material(19, 19, 38), Material::kPulp);
  EXPECT_EQ(vol->material(20, 20, 46), Material::kAir);
  EXPECT_EQ(rep.pulp_enclosed, 0);
  EXPECT_GT(rep.pulp_open, 8 * 8 * 12);
}

// ---- the real CT ---------------------------------------------------------------

struct Stats {
  double mean_dist = 0;
  Eigen::Vector3i lo{1 << 20, 1 << 20, 1 << 20}, hi{-1, -1, -1};
  std::int64_t n = 0;
};

TEST(SegmentationRealCt, ToothLayersAreNested) {
  const fs::path data = test::shared_data_dir();
  if (data.empty()) GTEST_SKIP() << "../shared/data is absent: real-CT test skipped";
  const fs::path raw = data / "tooth_103x94x161_uint8.raw";
  if (!fs::exists(raw)) GTEST_SKIP() << raw << " is absent: real-CT test skipped";
  ASSERT_EQ(fs::file_size(raw), 1558802u) << "unexpected size of " << raw;

  const fs::path dir = test::temp_dir("ct");
  const std::string json = (dir / "tooth.json").string();
  test::write_file(json, "{\"format\":\"dentar-raw\",\"version\":1,\"data\":\"" + raw.string() +
                             "\",\"dims\":[103,94,161],\"type\":\"uint8\","
                             "\"spacing_mm\":[0.1,0.1,0.1]}");
  auto v = load_volume(json);
  ASSERT_TRUE(v.ok()) << v.error();

  // Why auto_thresholds does not use a plain 3-level Otsu: its lowest
  // threshold splits the background (~64-95) instead of isolating the pulp.
  const auto otsu3 = multi_otsu(*v, 3);
  std::printf("3-level Otsu: %.1f %.1f %.1f\n", otsu3[0], otsu3[1], otsu3[2]);
  EXPECT_GT(otsu3[0], 90.f);

  auto t = auto_thresholds(*v);
  ASSERT_TRUE(t.ok()) << t.error();
  std::printf("auto thresholds: dark_max %.1f, background %.1f, tooth_min %.1f, enamel_min %.1f\n",
              t->dark_max, t->background, t->tooth_min, t->enamel_min);
  EXPECT_GT(t->dark_max, 50.f);
  EXPECT_LT(t->dark_max, 72.f);
  EXPECT_GT(t->tooth_min, 100.f);
  EXPECT_LT(t->tooth_min, 144.f);
  EXPECT_GT(t->enamel_min, 176.f);
  EXPECT_LT(t->enamel_min, 224.f);

  SegmentationReport rep;
  auto vol = segment_ct(*v, *t, &rep);
  ASSERT_TRUE(vol.ok()) << vol.error();
  const auto count = [&](Material m) { return rep.voxels[static_cast<std::size_t>(m)]; };
  std::printf(
      "voxels: air %lld, enamel %lld, dentin %lld, pulp %lld (enclosed %lld, open canal %lld); "
      "chunks %d of %d\n",
      static_cast<long long>(count(Material::kAir)),
      static_cast<long long>(count(Material::kEnamel)),
      static_cast<long long>(count(Material::kDentin)),
      static_cast<long long>(count(Material::kPulp)), static_cast<long long>(rep.pulp_enclosed),
      static_cast<long long>(rep.pulp_open), vol->allocated_chunks(), vol->num_chunks());
  EXPECT_GT(count(Material::kEnamel), 30000);
  EXPECT_GT(count(Material::kDentin), 200000);
  EXPECT_GT(count(Material::kPulp), 5000);
  EXPECT_LT(count(Material::kPulp), count(Material::kDentin) / 5);
  EXPECT_GT(count(Material::kAir), count(Material::kEnamel) + count(Material::kDentin));
  EXPECT_LT(vol->allocated_chunks(), vol->num_chunks());

  // Geometry of the layers, relative to the tooth centroid.
  const Eigen::Vector3i d = vol->dims();
  Eigen::Vector3d centroid(0, 0, 0);
  std::int64_t tooth_n = 0;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const Material m = vol->material(i, j, k);
        if (m == Material::kEnamel || m == Material::kDentin) {
          centroid += Eigen::Vector3d(i, j, k);
          ++tooth_n;
        }
      }
  centroid /= static_cast<double>(tooth_n);
  std::array<Stats, kNumMaterials> st;
  std::int64_t enamel_touching_pulp = 0, pulp_touching_air = 0;
  const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const Material m = vol->material(i, j, k);
        auto& s = st[static_cast<std::size_t>(m)];
        s.mean_dist += (Eigen::Vector3d(i, j, k) - centroid).norm();
        ++s.n;
        s.lo = s.lo.cwiseMin(Eigen::Vector3i(i, j, k));
        s.hi = s.hi.cwiseMax(Eigen::Vector3i(i, j, k));
        bool touches_pulp = false, touches_air = false;
        for (const auto& o : nb) {
          const Material q = vol->material(i + o[0], j + o[1], k + o[2]);
          touches_pulp |= q == Material::kPulp;
          touches_air |= q == Material::kAir;
        }
        if (m == Material::kEnamel && touches_pulp) ++enamel_touching_pulp;
        if (m == Material::kPulp && touches_air) ++pulp_touching_air;
      }
  for (auto& s : st)
    if (s.n) s.mean_dist /= static_cast<double>(s.n);
  const auto& enamel = st[static_cast<std::size_t>(Material::kEnamel)];
  const auto& dentin = st[static_cast<std::size_t>(Material::kDentin)];
  const auto& pulp = st[static_cast<std::size_t>(Material::kPulp)];
  std::printf(
      "mean distance from the tooth centroid (voxels): enamel %.1f, dentin %.1f, pulp %.1f\n",
      enamel.mean_dist, dentin.mean_dist, pulp.mean_dist);
  std::printf("enamel touching pulp %lld, pulp touching air %lld\n",
              static_cast<long long>(enamel_touching_pulp),
              static_cast<long long>(pulp_touching_air));
  // Enamel is the outer layer, pulp the inner one.
  EXPECT_GT(enamel.mean_dist, dentin.mean_dist);
  EXPECT_LT(pulp.mean_dist, dentin.mean_dist);
  EXPECT_LT(enamel_touching_pulp, enamel.n / 100);
  // Pulp lies inside dentin: its bounding box within dentin's, and hardly any
  // pulp voxel borders air (only where the canal leaves the cut root).
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(pulp.lo[a], dentin.lo[a]) << "axis " << a;
    EXPECT_LE(pulp.hi[a], dentin.hi[a]) << "axis " << a;
  }
  EXPECT_LT(pulp_touching_air, pulp.n / 50);
}

}  // namespace
}  // namespace dentar::volume
