// V4L2 camera listing for error messages (`dentar live` without a camera).
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <vector>

#include "dentar/live/live_app.h"
#include "dentar/live/station_health.h"

namespace dentar::live {

std::string camera_identity(const std::string& spec) {
  namespace fs = std::filesystem;
  std::string dev;
  if (spec.rfind("camera:", 0) == 0) dev = "/dev/video" + spec.substr(7);
  else if (spec.rfind("/dev/video", 0) == 0) dev = spec;
  if (dev.empty()) {
    const std::string path = spec.rfind("live:", 0) == 0 ? spec.substr(5) : spec;
    // The folder and the file (synth writes every clip as <out>/video.mkv).
    const fs::path p = fs::absolute(path).lexically_normal();
    return "footage " + (p.parent_path().filename() / p.filename()).string();
  }
  const int fd = ::open(dev.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) return {};
  v4l2_capability cap{};
  std::string id;
  if (ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0)
    id = std::string(reinterpret_cast<const char*>(cap.card)) + " @ " + reinterpret_cast<const char*>(cap.bus_info);
  ::close(fd);
  return id;
}

std::string list_cameras() {
  namespace fs = std::filesystem;
  std::vector<std::string> devs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/dev", ec))
    if (e.path().filename().string().rfind("video", 0) == 0) devs.push_back(e.path().string());
  std::sort(devs.begin(), devs.end());
  if (devs.empty()) return "no V4L2 camera found (/dev/video* does not exist): plug in a UVC webcam";
  std::ostringstream out;
  for (const auto& d : devs) {
    const int fd = ::open(d.c_str(), O_RDWR | O_NONBLOCK);
    if (fd < 0) {
      out << d << ": cannot open (" << (errno == EACCES ? "no permission: add yourself to group video" : "busy or gone")
          << ")\n";
      continue;
    }
    v4l2_capability cap{};
    if (ioctl(fd, VIDIOC_QUERYCAP, &cap) != 0 || !(cap.device_caps & V4L2_CAP_VIDEO_CAPTURE)) {
      ::close(fd);
      continue;  // metadata nodes of a UVC camera
    }
    out << d << " (" << reinterpret_cast<const char*>(cap.card) << "):";
    v4l2_fmtdesc fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    for (fmt.index = 0; ioctl(fd, VIDIOC_ENUM_FMT, &fmt) == 0 && fmt.index < 16; ++fmt.index) {
      const char fourcc[5] = {char(fmt.pixelformat & 0xff), char((fmt.pixelformat >> 8) & 0xff),
                              char((fmt.pixelformat >> 16) & 0xff), char((fmt.pixelformat >> 24) & 0xff), 0};
      out << " " << fourcc;
      v4l2_frmsizeenum fs{};
      fs.pixel_format = fmt.pixelformat;
      for (fs.index = 0; ioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) == 0 && fs.index < 12; ++fs.index)
        if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE)
          out << (fs.index ? "," : " ") << fs.discrete.width << "x" << fs.discrete.height;
    }
    out << "\n";
    ::close(fd);
  }
  std::string s = out.str();
  return s.empty() ? "no video-capture device among " + std::to_string(devs.size()) + " /dev/video* nodes" : s;
}

}  // namespace dentar::live
