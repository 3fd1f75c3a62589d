// Writes the writer-made seeds of corpus/fuzz_camera_file/ (OpenCV YAML and XML, ROS
// camera_info; 5- and 8-coefficient models). Rerun after a format change: build the target
// calibration_fuzz_seeds, then run
//   <build dir>/calibration/fuzz/make_seed_corpus calibration/fuzz/corpus/fuzz_camera_file
// The hand-written seeds there (OpenCV tutorial spelling) are not touched.
#include <cstdio>
#include <string>

#include "dentar/calibration/camera_file.h"

int main(int argc, char** argv) {
  namespace cal = dentar::calibration;
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <corpus dir>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  cal::CameraFile f;
  f.camera.width = 640;
  f.camera.height = 480;
  f.camera.fx = 600.5;
  f.camera.fy = 601.25;
  f.camera.cx = 322.06;
  f.camera.cy = 238.06;
  f.camera.dist = {-0.12, 0.06, 0.0004, -0.0003, 0.001};
  f.dist.assign(f.camera.dist.begin(), f.camera.dist.end());
  f.rms_px = 0.31;
  f.std_devs = {0.8, 0.8, 0.5, 0.5, 0.002, 0.01, 0.0001, 0.0001, 0.02};
  f.date = "2026-11-22T01:30:00Z";
  f.device = "logitech c920 #12";
  f.camera_name = "head_camera";
  f.views_used = 24;
  cal::CameraFile r = f;  // rational model, k4..k6 set
  r.model = cal::kModelRational8;
  r.dist.insert(r.dist.end(), {0.01, -0.002, 0.0003});
  r.std_devs.insert(r.std_devs.end(), {0.001, 0.001, 0.001});
  const struct {
    const char* name;
    const cal::CameraFile& file;
    bool ros;
  } seeds[] = {{"opencv_radtan5.yaml", f, false}, {"opencv_radtan5.xml", f, false},
               {"ros_plumb_bob.yaml", f, true},   {"opencv_rational8.yaml", r, false},
               {"opencv_rational8.xml", r, false}, {"ros_rational_polynomial.yaml", r, true}};
  for (const auto& s : seeds) {
    const std::string path = dir + "/" + s.name;
    const dentar::Status st =
        s.ros ? cal::write_ros_camera_info(path, s.file) : cal::write_camera_file(path, s.file);
    if (!st) {
      std::fprintf(stderr, "%s\n", st.error().c_str());
      return 1;
    }
  }
  return 0;
}
