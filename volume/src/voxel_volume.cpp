#include "dentar/volume/voxel_volume.h"

#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>
#include <sstream>

namespace dentar::volume {

std::string VolumeGeometry::validate() const {
  std::ostringstream os;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] <= 0 || dims[a] > kMaxDim) {
      os << "dims[" << a << "] = " << dims[a] << " is outside [1, " << kMaxDim << "]";
      return os.str();
    }
    if (!std::isfinite(spacing[a]) || spacing[a] <= 0.0) {
      os << "spacing[" << a << "] = " << spacing[a] << " m must be finite and > 0";
      return os.str();
    }
    if (spacing[a] > 1.0) {
      os << "spacing[" << a << "] = " << spacing[a]
         << " m is over 1 m per voxel; spacing is in metres (did you give millimetres?)";
      return os.str();
    }
    if (!std::isfinite(origin[a])) {
      os << "origin[" << a << "] = " << origin[a] << " must be finite";
      return os.str();
    }
  }
  if (voxel_count() > kMaxVoxels) {
    os << "dims " << dims.x() << "x" << dims.y() << "x" << dims.z() << " = " << voxel_count()
       << " voxels exceed the limit of " << kMaxVoxels;
    return os.str();
  }
  return {};
}

Result<VoxelVolume> VoxelVolume::create(const VolumeGeometry& g) {
  std::string why = g.validate();
  if (!why.empty()) return Error{"VoxelVolume: " + why};
  return VoxelVolume(g);
}

VoxelVolume::VoxelVolume(const VolumeGeometry& g) : geom_(g) {
  assert(g.validate().empty() && "dentar::volume::VoxelVolume: invalid geometry");
  for (int a = 0; a < 3; ++a) chunk_dims_[a] = (g.dims[a] + kChunkSize - 1) / kChunkSize;
  const auto n = static_cast<std::size_t>(chunk_dims_.prod());
  chunks_.resize(n);
  dirty_words_ = (n + 63) / 64;
  dirty_ = std::make_unique<std::atomic<std::uint64_t>[]>(dirty_words_);
  for (std::size_t w = 0; w < dirty_words_; ++w) dirty_[w].store(0, std::memory_order_relaxed);
}

VoxelVolume VoxelVolume::clone() const {
  VoxelVolume v(geom_);
  for (std::size_t c = 0; c < chunks_.size(); ++c)
    if (chunks_[c]) v.chunks_[c] = std::make_unique<Chunk>(*chunks_[c]);
  return v;
}

std::uint8_t VoxelVolume::density(int i, int j, int k) const {
  if (!in_bounds(i, j, k)) return 0;
  const Chunk* c = chunk(chunk_id(i >> kChunkBits, j >> kChunkBits, k >> kChunkBits));
  if (!c) return 0;
  return c->density[static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15))];
}

Material VoxelVolume::material(int i, int j, int k) const {
  if (!in_bounds(i, j, k)) return Material::kAir;
  const Chunk* c = chunk(chunk_id(i >> kChunkBits, j >> kChunkBits, k >> kChunkBits));
  if (!c) return Material::kAir;
  return static_cast<Material>(
      c->material[static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15))]);
}

void VoxelVolume::set(int i, int j, int k, std::uint8_t density, Material m) {
  assert(in_bounds(i, j, k) && "dentar::volume::VoxelVolume::set: voxel out of bounds");
  if (!in_bounds(i, j, k)) return;
  auto& slot = chunks_[static_cast<std::size_t>(
      chunk_id(i >> kChunkBits, j >> kChunkBits, k >> kChunkBits))];
  if (!slot) {
    if (density == 0 && m == Material::kAir) return;  // stays implicit air
    slot = std::make_unique<Chunk>();
  }
  const auto li = static_cast<std::size_t>(chunk_local_index(i & 15, j & 15, k & 15));
  slot->density[li] = density;
  slot->material[li] = static_cast<std::uint8_t>(m);
}

int VoxelVolume::allocated_chunks() const {
  int n = 0;
  for (const auto& c : chunks_) n += c ? 1 : 0;
  return n;
}

namespace {
bool chunk_is_empty(const VoxelVolume::Chunk& c) {
  for (std::size_t i = 0; i < c.density.size(); ++i)
    if (c.density[i] != 0 || c.material[i] != 0) return false;
  return true;
}
}  // namespace

int VoxelVolume::release_empty_chunks() {
  int n = 0;
  for (auto& c : chunks_) {
    if (c && chunk_is_empty(*c)) {
      c.reset();
      ++n;
    }
  }
  return n;
}

std::size_t VoxelVolume::memory_bytes() const {
  return static_cast<std::size_t>(allocated_chunks()) * sizeof(Chunk) +
         chunks_.size() * sizeof(chunks_[0]) + dirty_words_ * sizeof(std::uint64_t);
}

void VoxelVolume::mark_dirty(int id) noexcept {
  if (id < 0 || static_cast<std::size_t>(id) >= chunks_.size()) return;
  const auto u = static_cast<std::size_t>(id);
  dirty_[u >> 6].fetch_or(std::uint64_t{1} << (u & 63), std::memory_order_release);
}

void VoxelVolume::mark_dirty_box(const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) noexcept {
  Eigen::Vector3i clo, chi;
  for (int a = 0; a < 3; ++a) {
    const int l = std::max(lo[a], 0), h = std::min(hi[a], geom_.dims[a] - 1);
    if (l > h) return;
    clo[a] = l >> kChunkBits;
    chi[a] = h >> kChunkBits;
  }
  for (int ck = clo.z(); ck <= chi.z(); ++ck)
    for (int cj = clo.y(); cj <= chi.y(); ++cj)
      for (int ci = clo.x(); ci <= chi.x(); ++ci) mark_dirty(chunk_id(ci, cj, ck));
}

void VoxelVolume::mark_all_dirty() noexcept {
  for (int c = 0; c < num_chunks(); ++c) mark_dirty(c);
}

bool VoxelVolume::is_dirty(int id) const noexcept {
  if (id < 0 || static_cast<std::size_t>(id) >= chunks_.size()) return false;
  const auto u = static_cast<std::size_t>(id);
  return (dirty_[u >> 6].load(std::memory_order_acquire) >> (u & 63)) & 1u;
}

void VoxelVolume::drain_dirty(std::vector<int>& out) const {
  for (std::size_t w = 0; w < dirty_words_; ++w) {
    std::uint64_t bits = dirty_[w].exchange(0, std::memory_order_acq_rel);
    while (bits) {
      const int b = std::countr_zero(bits);
      bits &= bits - 1;
      out.push_back(static_cast<int>(w * 64 + static_cast<std::size_t>(b)));
    }
  }
}

namespace {
// 64-bit mixing (splitmix64 finaliser) for the content hash.
inline std::uint64_t mix64(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}
inline std::uint64_t hash_bytes(const std::uint8_t* p, std::size_t n, std::uint64_t h) {
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix64(h ^ w) + 0x9e3779b97f4a7c15ULL;
  }
  for (; i < n; ++i) h = mix64(h ^ p[i]);
  return h;
}
}  // namespace

std::uint64_t VoxelVolume::content_hash() const {
  std::uint64_t h = 0x6a09e667f3bcc908ULL;
  for (int a = 0; a < 3; ++a) {
    h = mix64(h ^ static_cast<std::uint64_t>(geom_.dims[a]));
    h = mix64(h ^ std::bit_cast<std::uint64_t>(geom_.spacing[a]));
    h = mix64(h ^ std::bit_cast<std::uint64_t>(geom_.origin[a]));
  }
  for (std::size_t c = 0; c < chunks_.size(); ++c) {
    const Chunk* ch = chunks_[c].get();
    if (!ch || chunk_is_empty(*ch)) continue;  // absent == all zero
    std::uint64_t hc = mix64(c + 1);
    hc = hash_bytes(ch->density.data(), ch->density.size(), hc);
    hc = hash_bytes(ch->material.data(), ch->material.size(), hc);
    h = mix64(h ^ hc) + c;
  }
  return h;
}

std::array<std::uint64_t, kMaxMaterials> VoxelVolume::density_sum_by_material() const {
  std::array<std::uint64_t, kMaxMaterials> s{};
  for (const auto& ch : chunks_) {
    if (!ch) continue;
    for (std::size_t i = 0; i < ch->density.size(); ++i)
      s[ch->material[i] & (kMaxMaterials - 1)] += ch->density[i];
  }
  return s;
}

}  // namespace dentar::volume
