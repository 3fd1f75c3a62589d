// CT intensity -> materials: multi-level Otsu, automatic dental thresholds and
// segment_ct (enamel / dentin / pulp / air with a remapped surface density).
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <vector>

#include "dentar/volume/image_volume.h"

namespace dentar::volume {

namespace {

constexpr int kBins = 256;

struct Histogram {
  std::array<double, kBins> count{};
  float lo = 0, hi = 0;  // value range; bin b holds [lo + b*w, lo + (b+1)*w)
  double width() const { return (static_cast<double>(hi) - lo) / kBins; }
  float edge(int b) const { return static_cast<float>(lo + width() * b); }
  double center(int b) const { return lo + width() * (b + 0.5); }
};

Histogram make_histogram(const std::vector<float>& values) {
  Histogram h;
  if (values.empty()) return h;
  const auto [mn, mx] = std::minmax_element(values.begin(), values.end());
  h.lo = *mn;
  h.hi = *mx;
  if (!(h.hi > h.lo)) return h;
  const double scale = kBins / (static_cast<double>(h.hi) - h.lo);
  for (const float x : values) {
    const int b = static_cast<int>((static_cast<double>(x) - h.lo) * scale);
    h.count[static_cast<std::size_t>(std::clamp(b, 0, kBins - 1))] += 1;
  }
  return h;
}

// Thresholds (bin indices, ascending) maximising the between-class variance of
// bins [first, kBins) split into levels+1 classes. Dynamic programming over
// class boundaries: O(levels * bins^2) instead of O(bins^levels).
std::vector<int> otsu_bins(const Histogram& h, int levels, int first) {
  std::array<double, kBins + 1> p{}, s{};
  for (int b = 0; b < kBins; ++b) {
    const double c = b >= first ? h.count[static_cast<std::size_t>(b)] : 0.0;
    p[static_cast<std::size_t>(b) + 1] = p[static_cast<std::size_t>(b)] + c;
    s[static_cast<std::size_t>(b) + 1] = s[static_cast<std::size_t>(b)] + c * b;
  }
  // Maximising sum_c S_c^2 / P_c is equivalent to maximising between-class variance.
  const auto cls = [&](int a, int b) {
    const double w = p[static_cast<std::size_t>(b)] - p[static_cast<std::size_t>(a)];
    const double m = s[static_cast<std::size_t>(b)] - s[static_cast<std::size_t>(a)];
    return w > 0 ? m * m / w : 0.0;
  };
  const int classes = levels + 1;
  // best[c][t]: best score of c+1 classes covering bins [first, t).
  std::vector<std::array<double, kBins + 1>> best(static_cast<std::size_t>(classes));
  std::vector<std::array<int, kBins + 1>> arg(static_cast<std::size_t>(classes));
  for (int t = 0; t <= kBins; ++t) best[0][static_cast<std::size_t>(t)] = cls(first, t);
  for (int c = 1; c < classes; ++c) {
    for (int t = first; t <= kBins; ++t) {
      double bv = -1;
      int ba = first + c;
      for (int a = first + c; a < t; ++a) {
        const double v =
            best[static_cast<std::size_t>(c) - 1][static_cast<std::size_t>(a)] + cls(a, t);
        if (v > bv) {
          bv = v;
          ba = a;
        }
      }
      best[static_cast<std::size_t>(c)][static_cast<std::size_t>(t)] = bv;
      arg[static_cast<std::size_t>(c)][static_cast<std::size_t>(t)] = ba;
    }
  }
  std::vector<int> th(static_cast<std::size_t>(levels));
  int t = kBins;
  for (int c = classes - 1; c >= 1; --c) {
    t = arg[static_cast<std::size_t>(c)][static_cast<std::size_t>(t)];
    th[static_cast<std::size_t>(c) - 1] = t;
  }
  return th;
}

std::string fmt(double x) {
  std::ostringstream os;
  os << x;
  return os.str();
}

}  // namespace

std::string Thresholds::validate() const {
  if (!std::isfinite(dark_max) || !std::isfinite(tooth_min) || !std::isfinite(enamel_min) ||
      !std::isfinite(background))
    return "thresholds must be finite";
  if (!(dark_max <= tooth_min))
    return "dark_max (" + fmt(dark_max) + ") must be <= tooth_min (" + fmt(tooth_min) + ")";
  if (!(tooth_min < enamel_min))
    return "tooth_min (" + fmt(tooth_min) + ") must be < enamel_min (" + fmt(enamel_min) + ")";
  if (!(background < tooth_min))
    return "background (" + fmt(background) + ") must be < tooth_min (" + fmt(tooth_min) + ")";
  return {};
}

std::vector<float> multi_otsu(const ImageVolume& v, int levels) {
  assert(levels >= 1 && levels <= 4 && "dentar::volume::multi_otsu: levels must be in [1, 4]");
  levels = std::clamp(levels, 1, 4);
  const Histogram h = make_histogram(v.values);
  if (!(h.hi > h.lo)) return std::vector<float>(static_cast<std::size_t>(levels), h.lo);
  std::vector<float> out;
  for (const int b : otsu_bins(h, levels, 0)) out.push_back(h.edge(b));
  return out;
}

Result<Thresholds> auto_thresholds(const ImageVolume& v) {
  const Histogram h = make_histogram(v.values);
  if (v.values.empty()) return Error{"auto_thresholds: the image is empty"};
  if (!(h.hi > h.lo))
    return Error{"auto_thresholds: the image is constant (" + fmt(h.lo) +
                 "); set thresholds by hand"};

  // 1. A first 2-level split (background | dentin | enamel) locates the tooth.
  const std::vector<int> first = otsu_bins(h, 2, 0);
  // 2. Background = the most common intensity below the tooth; its left flank
  //    (not contaminated by partial volume with the tooth) gives the noise sigma.
  int mode = 0;
  for (int b = 0; b < first[0]; ++b)
    if (h.count[static_cast<std::size_t>(b)] > h.count[static_cast<std::size_t>(mode)]) mode = b;
  const double peak = h.count[static_cast<std::size_t>(mode)];
  double hwhm_bins = 0.5;
  for (int b = mode - 1; b >= 0; --b) {
    const double c = h.count[static_cast<std::size_t>(b)];
    if (c < peak / 2) {
      const double c1 = h.count[static_cast<std::size_t>(b) + 1];
      hwhm_bins = (mode - b - 1) + (c1 - peak / 2) / std::max(c1 - c, 1e-9);
      break;
    }
  }
  hwhm_bins = std::max(hwhm_bins, 0.5);
  const double sigma_bins = hwhm_bins / 1.1774;  // Gaussian: HWHM = sqrt(2 ln 2) sigma
  // 3. Dark (pulp) = clearly below the background noise. A plain 3-level Otsu
  //    cannot find this class: on the shared tooth CT it splits the background
  //    peak (thresholds ~100/142/196) because pulp is <1% of the voxels.
  const double dark_bin = std::max(0.0, mode + 0.5 - 4.0 * sigma_bins);
  // 4. Tooth thresholds from a 2-level Otsu on the non-dark voxels, so a large
  //    dark class cannot drag the background/dentin split down.
  const int first_bin = std::clamp(static_cast<int>(dark_bin), 0, kBins - 3);
  const std::vector<int> tooth = otsu_bins(h, 2, first_bin);

  Thresholds t;
  t.dark_max = static_cast<float>(h.lo + h.width() * dark_bin);
  t.tooth_min = h.edge(tooth[0]);
  t.enamel_min = h.edge(tooth[1]);
  // Background level for the density ramp: the top of the background noise
  // (mode + 3 sigma), so empty space maps to 0 and allocates no chunk.
  t.background = static_cast<float>(std::min(h.center(mode) + 3.0 * sigma_bins * h.width(),
                                             static_cast<double>(t.tooth_min) - h.width()));
  if (t.background < t.dark_max) t.background = t.dark_max;
  if (!(h.center(mode) < t.tooth_min) || !(t.tooth_min < t.enamel_min) || !t.validate().empty())
    return Error{
        "auto_thresholds: no separable background/dentin/enamel classes (got "
        "background " +
        fmt(h.center(mode)) + ", tooth_min " + fmt(t.tooth_min) + ", enamel_min " +
        fmt(t.enamel_min) + "); set thresholds by hand"};
  return t;
}

namespace {

// The 26 neighbour directions.
std::array<std::array<int, 3>, 26> directions26() {
  std::array<std::array<int, 3>, 26> d{};
  int n = 0;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x)
        if (x || y || z) d[static_cast<std::size_t>(n++)] = {x, y, z};
  return d;
}

}  // namespace

Result<VoxelVolume> segment_ct(const ImageVolume& v, const Thresholds& t,
                               SegmentationReport* report) {
  if (const std::string why = t.validate(); !why.empty()) return Error{"segment_ct: " + why};
  if (const std::string why = v.geometry.validate(); !why.empty())
    return Error{"segment_ct: " + why};
  const Eigen::Vector3i d = v.geometry.dims;
  const auto n = static_cast<std::size_t>(v.geometry.voxel_count());
  if (v.values.size() != n) return Error{"segment_ct: values.size() does not match dims"};
  auto vol = VoxelVolume::create(v.geometry);
  if (!vol) return Error{vol.error()};

  const std::size_t sx = 1, sy = static_cast<std::size_t>(d.x()),
                    sz = static_cast<std::size_t>(d.x()) * static_cast<std::size_t>(d.y());
  enum : std::uint8_t { kNonTooth = 0, kTooth = 1, kOutside = 2, kPulp = 3 };
  std::vector<std::uint8_t> cls(n);
  for (std::size_t i = 0; i < n; ++i) cls[i] = v.values[i] >= t.tooth_min ? kTooth : kNonTooth;

  // 1. Outside = non-tooth voxels connected (6-neighbours) to the volume border.
  std::vector<std::uint32_t> queue;
  const auto push = [&](std::size_t i) {
    if (cls[i] == kNonTooth) {
      cls[i] = kOutside;
      queue.push_back(static_cast<std::uint32_t>(i));
    }
  };
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i)
        if (i == 0 || j == 0 || k == 0 || i == d.x() - 1 || j == d.y() - 1 || k == d.z() - 1)
          push(v.index(i, j, k));
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::size_t id = queue[q];
    const auto i = static_cast<int>(id % sy),
               j = static_cast<int>((id / sy) % static_cast<std::size_t>(d.y())),
               k = static_cast<int>(id / sz);
    if (i > 0) push(id - sx);
    if (i < d.x() - 1) push(id + sx);
    if (j > 0) push(id - sy);
    if (j < d.y() - 1) push(id + sy);
    if (k > 0) push(id - sz);
    if (k < d.z() - 1) push(id + sz);
  }

  // 2. Enclosed non-tooth voxels are the pulp chamber and canals. All of them
  //    are pulp, whatever their intensity: the partial-volume shell between a
  //    dark pulp and dentin is pulp too, not a film of air around it.
  std::int64_t enclosed = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (cls[i] == kNonTooth) {
      cls[i] = kPulp;
      ++enclosed;
    }

  // 3. Open canals. A root canal that leaves the tooth (open apex, or a root
  //    cut by the scan's field of view) connects the
  //    pulp to the outside, and step 1 would call it air. We do not close the
  //    tooth morphologically (that also seals fissures and the furcation and
  //    turns them into "pulp"); instead a dark voxel (< dark_max, darker than
  //    any background) counts as pulp when rays in at least kMinHits of the 26
  //    directions hit tooth within kRayVoxels; the region then grows through
  //    outside non-tooth voxels passing the same test (the canal's
  //    partial-volume wall). A canal opens only along its axis, so its voxels
  //    see tooth in almost all directions; a background voxel in a concavity
  //    does not. On the shared tooth CT the chamber and canals are enclosed
  //    (17264 voxels); the ~490 dark voxels that do reach the border sit where
  //    the scan cuts the root and its wall is open sideways (not enclosed even
  //    within their axial slice; rays hit tooth in <= 19 of 26 directions), so
  //    they stay air: the open, cut end of the root.
  constexpr int kRayVoxels = 48;
  constexpr int kMinHits = 21;
  const auto dirs = directions26();
  const auto enclosed_by_tooth = [&](int i, int j, int k) {
    int misses = 0;
    for (const auto& dir : dirs) {
      bool hit = false;
      int x = i, y = j, z = k;
      for (int s = 0; s < kRayVoxels; ++s) {
        x += dir[0];
        y += dir[1];
        z += dir[2];
        if (x < 0 || y < 0 || z < 0 || x >= d.x() || y >= d.y() || z >= d.z()) break;
        if (cls[v.index(x, y, z)] == kTooth) {
          hit = true;
          break;
        }
      }
      if (!hit && ++misses > 26 - kMinHits) return false;
    }
    return true;
  };
  queue.clear();
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const std::size_t id = v.index(i, j, k);
        if (cls[id] == kOutside && v.values[id] < t.dark_max && enclosed_by_tooth(i, j, k)) {
          cls[id] = kPulp;
          queue.push_back(static_cast<std::uint32_t>(id));
        }
      }
  std::int64_t open = 0;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    ++open;
    const std::size_t id = queue[q];
    const auto i = static_cast<int>(id % sy),
               j = static_cast<int>((id / sy) % static_cast<std::size_t>(d.y())),
               k = static_cast<int>(id / sz);
    const std::array<std::array<int, 3>, 6> nb = {
        {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}}};
    for (const auto& p : nb) {
      if (p[0] < 0 || p[1] < 0 || p[2] < 0 || p[0] >= d.x() || p[1] >= d.y() || p[2] >= d.z())
        continue;
      const std::size_t nid = v.index(p[0], p[1], p[2]);
      if (cls[nid] == kOutside && enclosed_by_tooth(p[0], p[1], p[2])) {
        cls[nid] = kPulp;
        queue.push_back(static_cast<std::uint32_t>(nid));
      }
    }
  }
  std::vector<std::uint32_t>().swap(queue);

  // 4. Materials and densities. Density ramps linearly from background (0) to
  //    tooth_min (kIsoDensity). Air keeps its ramp value only next to tooth
  //    (26-neighbourhood), where it places the surface between voxels;
  //    elsewhere it is 0, so empty space and background noise allocate no chunk.
  const double ramp = kIsoDensity / (static_cast<double>(t.tooth_min) - t.background);
  const auto remap = [&](float x) {
    return std::clamp((static_cast<double>(x) - t.background) * ramp, 0.0, 255.0);
  };
  const auto near_tooth = [&](int i, int j, int k) {
    for (const auto& dir : dirs) {
      const int x = i + dir[0], y = j + dir[1], z = k + dir[2];
      if (x >= 0 && y >= 0 && z >= 0 && x < d.x() && y < d.y() && z < d.z() &&
          cls[v.index(x, y, z)] == kTooth)
        return true;
    }
    return false;
  };
  SegmentationReport rep;
  rep.thresholds = t;
  rep.pulp_enclosed = enclosed;
  rep.pulp_open = open;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const std::size_t id = v.index(i, j, k);
        const float x = v.values[id];
        Material m = Material::kAir;
        std::uint8_t dens = 0;
        if (cls[id] == kTooth) {
          m = x >= t.enamel_min ? Material::kEnamel : Material::kDentin;
          dens = static_cast<std::uint8_t>(std::max(128.0, std::round(remap(x))));
        } else {
          const bool pulp = cls[id] == kPulp;
          m = pulp ? Material::kPulp : Material::kAir;
          if (pulp || near_tooth(i, j, k))
            dens = static_cast<std::uint8_t>(std::min(127.0, std::round(remap(x))));
        }
        ++rep.voxels[static_cast<std::size_t>(m)];
        vol->set(i, j, k, dens, m);
      }
  if (report) *report = rep;
  return std::move(vol.value());
}

}  // namespace dentar::volume
