// The Swarmathon AprilTag photos' reference corners (tests/data/apriltag_photos, provenance in
// tests/data_provenance.md), read the one way the tests that use them need.
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace dentar::ar::test {

struct SwarmRef {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners;  // px, OpenCV's pixel centres (libapriltag's - 0.5)
};

// Lines "id, (x0 y0), (x1 y1), (x2 y2), (x3 y3)" in libapriltag's convention (+0.5 px); other
// lines are skipped. Empty when the file is absent.
inline std::vector<SwarmRef> read_swarm_refs(const std::filesystem::path& txt) {
  std::vector<SwarmRef> out;
  std::ifstream in(txt);
  std::string line;
  while (in && std::getline(in, line)) {
    for (char& ch : line)
      if (ch == ',' || ch == '(' || ch == ')') ch = ' ';
    std::istringstream ls(line);
    SwarmRef r;
    double v[8];
    if (!(ls >> r.id >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6] >> v[7])) continue;
    for (int i = 0; i < 4; ++i) r.corners[static_cast<std::size_t>(i)] = Eigen::Vector2d(v[2 * i] - 0.5, v[2 * i + 1] - 0.5);
    out.push_back(r);
  }
  return out;
}

}  // namespace dentar::ar::test
