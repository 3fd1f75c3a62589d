#include "dentar/volume/voxel_volume.h"

#include <gtest/gtest.h>

#include <thread>

namespace dentar::volume {
namespace {

VolumeGeometry geom(int x, int y, int z) {
  VolumeGeometry g;
  g.dims = {x, y, z};
  g.spacing = {1e-4, 2e-4, 3e-4};
  g.origin = {0.01, -0.02, 0.03};
  return g;
}

TEST(VoxelVolume, ChunkGridCoversNonMultipleDims) {
  VoxelVolume v(geom(17, 32, 33));
  EXPECT_EQ(v.chunk_dims(), Eigen::Vector3i(2, 2, 3));
  EXPECT_EQ(v.num_chunks(), 12);
  EXPECT_EQ(v.allocated_chunks(), 0);
}

TEST(VoxelVolume, AirIsNotAllocatedAndSolidIs) {
  VoxelVolume v(geom(40, 40, 40));
  v.set(3, 4, 5, 0, Material::kAir);
  EXPECT_EQ(v.allocated_chunks(), 0);
  v.set(20, 33, 39, 200, Material::kDentin);
  EXPECT_EQ(v.allocated_chunks(), 1);
  EXPECT_EQ(v.density(20, 33, 39), 200);
  EXPECT_EQ(v.material(20, 33, 39), Material::kDentin);
  EXPECT_EQ(v.density(21, 33, 39), 0);
  EXPECT_EQ(v.material(-1, 0, 0), Material::kAir);
  EXPECT_EQ(v.density(40, 0, 0), 0);
  EXPECT_TRUE(v.chunk(v.chunk_id(1, 2, 2)) != nullptr);
  EXPECT_LT(v.memory_bytes(), v.dense_bytes());
  v.set(20, 33, 39, 0, Material::kAir);
  EXPECT_EQ(v.release_empty_chunks(), 1);
  EXPECT_EQ(v.allocated_chunks(), 0);
}

TEST(VoxelVolume, VoxelCentreUsesOriginAndPerAxisSpacing) {
  VoxelVolume v(geom(4, 4, 4));
  const Eigen::Vector3d c = v.voxel_center(1, 2, 3);
  EXPECT_DOUBLE_EQ(c.x(), 0.01 + 1e-4);
  EXPECT_DOUBLE_EQ(c.y(), -0.02 + 4e-4);
  EXPECT_DOUBLE_EQ(c.z(), 0.03 + 9e-4);
}

TEST(VoxelVolume, CreateRejectsBadGeometryNamingTheField) {
  auto g = geom(10, 10, 10);
  g.spacing.y() = 0;
  auto r = VoxelVolume::create(g);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("spacing[1]"), std::string::npos) << r.error();
  g = geom(10, 10, 10);
  g.spacing.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(VoxelVolume::create(g).error().find("spacing[2]"), std::string::npos);
  g = geom(10, 0, 10);
  EXPECT_NE(VoxelVolume::create(g).error().find("dims[1]"), std::string::npos);
  g = geom(4096, 4096, 4096);
  EXPECT_NE(VoxelVolume::create(g).error().find("exceed"), std::string::npos);
  g = geom(10, 10, 10);
  g.spacing.x() = 5.0;  // 5 m per voxel: a unit slip
  EXPECT_NE(VoxelVolume::create(g).error().find("millimetres"), std::string::npos);
}

TEST(VoxelVolume, DirtyBoxMarksEveryChunkOnceAndDrainClears) {
  VoxelVolume v(geom(64, 64, 64));
  v.mark_dirty_box({15, 15, 15}, {16, 16, 16});  // straddles 8 chunks
  std::vector<int> ids;
  v.drain_dirty(ids);
  EXPECT_EQ(ids.size(), 8u);
  EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
  ids.clear();
  v.drain_dirty(ids);
  EXPECT_TRUE(ids.empty());
  v.mark_dirty_box({-5, -5, -5}, {0, 0, 0});  // clamped to chunk 0
  v.mark_dirty_box({70, 0, 0}, {80, 1, 1});   // entirely outside: nothing
  v.drain_dirty(ids);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], 0);
}

TEST(VoxelVolume, DirtyMarksFromAnotherThreadAreNeverLost) {
  VoxelVolume v(geom(256, 256, 64));  // 1024 chunks: several bitset words
  std::vector<int> seen(static_cast<std::size_t>(v.num_chunks()), 0);
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int round = 0; round < 50; ++round)
      for (int c = 0; c < v.num_chunks(); ++c) v.mark_dirty(c);
    done = true;
  });
  std::vector<int> ids;
  while (!done.load()) {
    ids.clear();
    v.drain_dirty(ids);
    for (int id : ids) seen[static_cast<std::size_t>(id)] = 1;
  }
  writer.join();
  ids.clear();
  v.drain_dirty(ids);
  for (int id : ids) seen[static_cast<std::size_t>(id)] = 1;
  for (int c = 0; c < v.num_chunks(); ++c) EXPECT_EQ(seen[static_cast<std::size_t>(c)], 1) << c;
}

TEST(VoxelVolume, HashSeesEveryVoxelAndIgnoresAllocationState) {
  VoxelVolume a(geom(40, 40, 40)), b(geom(40, 40, 40));
  EXPECT_EQ(a.content_hash(), b.content_hash());
  a.set(1, 2, 3, 100, Material::kEnamel);
  EXPECT_NE(a.content_hash(), b.content_hash());
  b.set(1, 2, 3, 100, Material::kEnamel);
  EXPECT_EQ(a.content_hash(), b.content_hash());
  b.set(1, 2, 3, 100, Material::kDentin);  // same density, other label
  EXPECT_NE(a.content_hash(), b.content_hash());
  b.set(1, 2, 3, 100, Material::kEnamel);
  b.set(30, 30, 30, 1, Material::kAir);  // allocates a chunk...
  EXPECT_NE(a.content_hash(), b.content_hash());
  b.set(30, 30, 30, 0, Material::kAir);  // ...that is all zero again
  EXPECT_EQ(a.content_hash(), b.content_hash());
  VoxelVolume c = a.clone();
  EXPECT_EQ(c.content_hash(), a.content_hash());
  auto g = geom(40, 40, 40);
  g.spacing.x() = 1.01e-4;
  VoxelVolume d(g);
  d.set(1, 2, 3, 100, Material::kEnamel);
  EXPECT_NE(d.content_hash(), a.content_hash());
}

TEST(VoxelVolume, DensitySumsPerMaterial) {
  VoxelVolume v(geom(40, 40, 40));
  v.set(0, 0, 0, 10, Material::kEnamel);
  v.set(39, 39, 39, 20, Material::kEnamel);
  v.set(5, 5, 5, 7, Material::kPulp);
  const auto s = v.density_sum_by_material();
  EXPECT_EQ(s[static_cast<int>(Material::kEnamel)], 30u);
  EXPECT_EQ(s[static_cast<int>(Material::kPulp)], 7u);
  EXPECT_EQ(s[static_cast<int>(Material::kDentin)], 0u);
}

}  // namespace
}  // namespace dentar::volume
