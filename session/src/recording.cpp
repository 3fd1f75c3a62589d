// Reading a live recording folder back. See recording.h.
#include "dentar/session/recording.h"

#include <exception>
#include <fstream>
#include <nlohmann/json.hpp>

#include "dentar/session/recording_table.h"

namespace dentar::session {
namespace fs = std::filesystem;

Result<Recording> read_recording(const fs::path& dir) {
  Recording rec;
  rec.present = true;
  const fs::path meta = dir / "recording.json";
  std::ifstream mj(meta);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(mj);
  } catch (const std::exception& e) {
    return Error{meta.string() + ": not valid JSON (" + e.what() + ")"};
  }
  if (!j.is_object() || !j.contains("format") || !j["format"].is_string() || j["format"] != "dentar-recording")
    return Error{meta.string() + ": format must be \"dentar-recording\""};
  if (j.contains("discovery") && !j["discovery"].is_string())
    return Error{meta.string() + ": discovery must be the string \"inline\" or \"async\""};
  rec.discovery = j.value("discovery", "inline");
  if (rec.discovery != "inline" && rec.discovery != "async")
    return Error{meta.string() + ": discovery = \"" + rec.discovery + "\" must be inline or async"};
  if (j.contains("camera_response")) {
    if (!j["camera_response"].is_string())
      return Error{meta.string() + ": camera_response must be the string \"srgb\" or \"linear\""};
    auto r = ar::parse_camera_response(j["camera_response"].get<std::string>());
    if (!r) return Error{meta.string() + ": camera_response: " + r.error()};
    rec.camera_response = *r;
  }
  if (j.contains("mirror_rim")) {
    if (!j["mirror_rim"].is_boolean()) return Error{meta.string() + ": mirror_rim must be true or false"};
    rec.mirror_rim = j["mirror_rim"].get<bool>();
  }
  if (j.contains("stereo_mirror_rim")) {
    if (!j["stereo_mirror_rim"].is_boolean())
      return Error{meta.string() + ": stereo_mirror_rim must be true or false"};
    rec.stereo_mirror_rim = j["stereo_mirror_rim"].get<bool>();
  }
  if (j.contains("jpeg_decode")) {
    if (!j["jpeg_decode"].is_string() || (j["jpeg_decode"] != "yuyv" && j["jpeg_decode"] != "bgr"))
      return Error{meta.string() + ": jpeg_decode must be the string \"yuyv\" or \"bgr\""};
    rec.jpeg_decode = j["jpeg_decode"].get<std::string>();
  }
  if (j.contains("predict_ms")) {
    if (!j["predict_ms"].is_number() || !(j["predict_ms"].get<double>() >= 0 && j["predict_ms"].get<double>() <= 500))
      return Error{meta.string() + ": predict_ms must be a number of milliseconds in 0..500"};
    rec.predict_ms = j["predict_ms"].get<double>();
  }
  if (j.contains("stereo")) {
    const auto& sj = j["stereo"];
    if (!sj.is_object() || !sj.contains("head") || !sj["head"].is_string() ||
        (sj["head"] != "two_cameras" && sj["head"] != "side_by_side"))
      return Error{meta.string() + ": stereo must be an object whose head is \"two_cameras\" or \"side_by_side\""};
    rec.stereo = true;
    rec.stereo_head = sj["head"].get<std::string>();
    if (!fs::is_directory(dir / "frames_right"))
      return Error{(dir / "frames_right").string() + ": missing: recording.json says the run was stereo, and the "
                   "right eye's frames are kept there"};
  }
  rec.frames_csv = (dir / "frames.csv").string();
  std::ifstream in(rec.frames_csv);
  if (!in) return Error{rec.frames_csv + ": missing: the recording has no per-frame table"};
  auto table = parse_recording_table(in, rec.discovery == "async", rec.frames_csv, rec.stereo);
  if (!table) return Error{table.error()};
  rec.capture_s = std::move(table->capture_s);
  rec.haptic_steps = std::move(table->haptic_steps);
  rec.pose_step = std::move(table->pose_step);
  rec.cues = std::move(table->cues);
  rec.cues_exact = table->cues_exact;
  rec.eyes = std::move(table->eyes);
  return rec;
}


}  // namespace dentar::session
