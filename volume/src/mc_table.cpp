// Generates the marching-cubes case table from first principles instead of
// shipping a published table:
//  1. On each face, iso-segments join the crossed face edges. An ambiguous
//     face (inside corners on one diagonal, outside on the other) always
//     separates the inside corners. The rule looks only at the face's own
//     corners, so the two cells sharing a face draw the same segments and the
//     surface has no cracks.
//  2. Each segment gets the direction o x n_face, where n_face is the face's
//     outward normal and o points (within the face) from the segment toward
//     the outside corners. A polygon spanning the linked loop then lies to
//     the left of each side seen along its normal, and that normal points from
//     inside to outside (toward lower density).
//  3. Segments are linked into closed loops (every crossed edge starts one
//     segment and ends one) and each loop is triangulated by a minimum total
//     diagonal length triangulation that never uses a diagonal between two
//     edges of a common face: such a diagonal would lie in the face and be
//     shared with the neighbouring cell's triangles, breaking 2-manifoldness.
#include "mc_table.h"

#include <cassert>
#include <cmath>
#include <limits>

namespace dentar::volume::mc {
namespace {

struct V3 {
  double x, y, z;
  V3 operator+(const V3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(double s) const { return {x * s, y * s, z * s}; }
  double dot(const V3& o) const { return x * o.x + y * o.y + z * o.z; }
  V3 cross(const V3& o) const { return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x}; }
  double norm() const { return std::sqrt(dot(*this)); }
};

V3 corner_pos(int c) { return {double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)}; }
V3 edge_mid(int e) {
  return (corner_pos(edge_base_corner(e)) + corner_pos(edge_tip_corner(e))) * 0.5;
}
bool inside(int mask, int corner) { return (mask >> corner) & 1; }

int edge_between(int c0, int c1) {
  const int diff = c0 ^ c1;
  const int axis = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int base = c0 < c1 ? c0 : c1;
  for (int e = 4 * axis; e < 4 * axis + 4; ++e)
    if (edge_base_corner(e) == base) return e;
  assert(false && "dentar::volume::mc::edge_between: corners are not adjacent");
  return -1;
}

// Corners of face f in cyclic order around the face.
std::array<int, 4> face_corners(int face) {
  const int a = face >> 1, side = face & 1;
  const int u = (a + 1) % 3, v = (a + 2) % 3;
  const int cu[4] = {0, 1, 1, 0}, cv[4] = {0, 0, 1, 1};
  std::array<int, 4> c{};
  for (int i = 0; i < 4; ++i) c[i] = (side << a) | (cu[i] << u) | (cv[i] << v);
  return c;
}

V3 face_normal(int face) {
  const double s = (face & 1) ? 1.0 : -1.0;
  const int a = face >> 1;
  return {a == 0 ? s : 0.0, a == 1 ? s : 0.0, a == 2 ? s : 0.0};
}

// Triangulates one closed loop (edge ids in order) into out, keeping the
// loop's orientation.
void triangulate_loop(const std::vector<int>& loop, std::vector<std::array<int, 3>>& out) {
  const int n = static_cast<int>(loop.size());
  assert(n >= 3 && "dentar::volume::mc::triangulate_loop: loop shorter than 3");
  constexpr double kForbidden = 1e6;
  auto diag_cost = [&](int i, int j) {
    if (j == i + 1 || (i == 0 && j == n - 1)) return 0.0;  // polygon side, not a diagonal
    if (edges_share_face(loop[i], loop[j])) return kForbidden;
    return (edge_mid(loop[i]) - edge_mid(loop[j])).norm();
  };
  // cost[i][j]: best triangulation of sub-polygon i..j; split[i][j]: its apex.
  std::vector<std::vector<double>> cost(n, std::vector<double>(n, 0.0));
  std::vector<std::vector<int>> split(n, std::vector<int>(n, -1));
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      double best = std::numeric_limits<double>::infinity();
      for (int k = i + 1; k < j; ++k) {
        const double c = cost[i][k] + cost[k][j] + diag_cost(i, k) + diag_cost(k, j);
        if (c < best - 1e-12) {
          best = c;
          split[i][j] = k;
        }
      }
      cost[i][j] = best;
    }
  }
  // Emit (i, k, j) in loop order so each triangle keeps the loop's winding.
  std::vector<std::array<int, 2>> stack = {{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    if (j - i < 2) continue;
    const int k = split[i][j];
    out.push_back({loop[i], loop[k], loop[j]});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
}

CaseTable build_table() {
  CaseTable t;
  for (int mask = 0; mask < kNumCases; ++mask) {
    std::uint16_t crossed = 0;
    for (int e = 0; e < kNumEdges; ++e)
      if (inside(mask, edge_base_corner(e)) != inside(mask, edge_tip_corner(e)))
        crossed = static_cast<std::uint16_t>(crossed | (1u << e));
    t.crossed_edges[mask] = crossed;

    std::vector<std::array<int, 3>> tris;
    for (const auto& loop : case_loops(mask)) triangulate_loop(loop, tris);
    assert(tris.size() <= static_cast<std::size_t>(kMaxTriangles) &&
           "dentar::volume::mc::build_table: too many triangles for one case");
    t.num_triangles[mask] = static_cast<std::uint8_t>(tris.size());
    for (std::size_t i = 0; i < tris.size(); ++i)
      for (int v = 0; v < 3; ++v)
        t.triangles[mask][3 * i + v] = static_cast<std::uint8_t>(tris[i][v]);
  }
  return t;
}

}  // namespace

bool edges_share_face(int a, int b) {
  const int aa = edge_axis(a), ab = edge_axis(b);
  const int ba = edge_base_corner(a), bb = edge_base_corner(b);
  for (int x = 0; x < 3; ++x) {
    if (x == aa || x == ab) continue;
    if (((ba >> x) & 1) == ((bb >> x) & 1)) return true;
  }
  return false;
}

std::vector<std::array<int, 2>> face_segments(int mask, int face) {
  const auto c = face_corners(face);
  bool in[4];
  int e[4];  // e[i] joins corner i and corner i+1
  int n_crossed = 0, n_in = 0;
  for (int i = 0; i < 4; ++i) {
    in[i] = inside(mask, c[i]);
    n_in += in[i] ? 1 : 0;
  }
  for (int i = 0; i < 4; ++i) {
    e[i] = edge_between(c[i], c[(i + 1) % 4]);
    n_crossed += in[i] != in[(i + 1) % 4] ? 1 : 0;
  }
  // Each segment with a vector o pointing (within the face) toward its
  // outside side.
  struct Seg {
    int a, b;
    V3 o;
  };
  std::vector<Seg> segs;
  if (n_crossed == 2) {
    int ends[2], k = 0;
    for (int i = 0; i < 4; ++i)
      if (in[i] != in[(i + 1) % 4]) ends[k++] = e[i];
    V3 cin{0, 0, 0}, cout{0, 0, 0};
    for (int i = 0; i < 4; ++i) {
      if (in[i])
        cin = cin + corner_pos(c[i]) * (1.0 / n_in);
      else
        cout = cout + corner_pos(c[i]) * (1.0 / (4 - n_in));
    }
    segs.push_back({ends[0], ends[1], cout - cin});
  } else if (n_crossed == 4) {
    // Ambiguous face: cut off each inside corner on its own.
    for (int i = 0; i < 4; ++i) {
      if (!in[i]) continue;
      const int ea = e[(i + 3) % 4], eb = e[i];
      const V3 mid = (edge_mid(ea) + edge_mid(eb)) * 0.5;
      segs.push_back({ea, eb, mid - corner_pos(c[i])});
    }
  }
  std::vector<std::array<int, 2>> out;
  const V3 n = face_normal(face);
  for (const Seg& s : segs) {
    const V3 dir = s.o.cross(n);
    if ((edge_mid(s.b) - edge_mid(s.a)).dot(dir) > 0)
      out.push_back({s.a, s.b});
    else
      out.push_back({s.b, s.a});
  }
  return out;
}

std::vector<std::vector<int>> case_loops(int mask) {
  int next[kNumEdges], prev[kNumEdges];
  for (int e = 0; e < kNumEdges; ++e) next[e] = prev[e] = -1;
  for (int f = 0; f < 6; ++f) {
    for (const auto& s : face_segments(mask, f)) {
      assert(next[s[0]] < 0 && prev[s[1]] < 0 &&
             "dentar::volume::mc::case_loops: edge used twice in one direction");
      next[s[0]] = s[1];
      prev[s[1]] = s[0];
    }
  }
  std::vector<std::vector<int>> loops;
  bool used[kNumEdges] = {};
  for (int start = 0; start < kNumEdges; ++start) {
    if (next[start] < 0 || used[start]) continue;
    std::vector<int> loop;
    int e = start;
    while (!used[e]) {
      used[e] = true;
      loop.push_back(e);
      e = next[e];
      assert(e >= 0 && "dentar::volume::mc::case_loops: open loop");
      if (e < 0) break;
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

const CaseTable& case_table() {
  static const CaseTable table = build_table();
  return table;
}

}  // namespace dentar::volume::mc
