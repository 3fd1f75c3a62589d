#include "dentar/calibration/camera_file.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/core.hpp>
#include <sstream>

namespace dentar::calibration {
namespace {

// Inside XML markup (between '<' and '>', outside quotes) every '=' must be
// followed by optional white space and a quote. Empty when fine, else where
// it is not.
std::string malformed_xml_attribute(const std::string& t) {
  bool in_tag = false;
  char quote = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (!in_tag) {
      in_tag = c == '<';
    } else if (c == '>') {
      in_tag = false;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '=') {
      std::size_t k = i + 1;
      while (k < t.size() && (t[k] == ' ' || t[k] == '\t' || t[k] == '\r' || t[k] == '\n')) ++k;
      if (k >= t.size() || (t[k] != '"' && t[k] != '\''))
        return "attribute value without quotes at byte " + std::to_string(i);
    }
  }
  if (quote) return "unterminated quoted value";
  return {};
}


std::string read_text(const std::string& path, std::string& err) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    err = path + ": cannot open the camera file (check the path and permissions)";
    return {};
  }
  // Camera files are a few KiB. A large file given here by mistake (a video, a CT volume)
  // would be read whole and handed to OpenCV's parser, which can then run for minutes: refuse
  // it up front.
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size > (1 << 20)) {
    err = path + ": " + std::to_string(size) + " bytes is far too large for a camera file (at "
          "most 1 MiB); give the calibration YAML/XML";
    return {};
  }
  in.seekg(0);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Writes `text` to path via a temporary file and a rename: no half-written file on failure.
Status write_text_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Error{path + ": cannot create the file (check the directory exists and is writable)"};
    out << text;
    out.flush();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return Error{path + ": write failed (disk full?)"};
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return Error{path + ": cannot rename the temporary file into place: " + ec.message()};
  }
  return {};
}

// First node found under any of `names` (OpenCV's samples and tutorials differ in case).
cv::FileNode find(const cv::FileNode& root, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    cv::FileNode f = root[n];
    if (!f.empty() && !f.isNone()) return f;
  }
  return cv::FileNode();
}

// A matrix given as !!opencv-matrix (rows, cols, dt, data), as a ROS map (rows, cols, data) or
// as a plain sequence (rows = 1). Returns an error text naming the field, or empty.
std::string read_matrix(const cv::FileNode& n, const std::string& field, std::vector<double>& data,
                        int& rows, int& cols) {
  data.clear();
  cv::FileNode seq = n;
  rows = 1;
  cols = 0;
  if (n.isMap()) {
    seq = n["data"];
    if (seq.empty() || !seq.isSeq()) return field + ": has no data sequence";
    if (!n["rows"].isInt() || !n["cols"].isInt())
      return field + ": rows and cols must be integers";
    rows = static_cast<int>(n["rows"]);
    cols = static_cast<int>(n["cols"]);
  } else if (!n.isSeq()) {
    return field + ": must be a matrix (rows, cols, data) or a sequence of numbers";
  }
  for (auto it = seq.begin(); it != seq.end(); ++it) {
    const cv::FileNode v = *it;
    if (!v.isReal() && !v.isInt()) return field + ".data: entries must be numbers";
    data.push_back(static_cast<double>(v));
  }
  if (!n.isMap()) cols = static_cast<int>(data.size());
  if (rows <= 0 || cols <= 0 || static_cast<std::size_t>(rows) * cols != data.size()) {
    std::ostringstream os;
    os << field << ": rows x cols = " << rows << " x " << cols << " does not match the "
       << data.size() << " data entries";
    return os.str();
  }
  return {};
}

std::string iso_now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

Result<CameraFile> parse(const std::string& path, const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return Error{path + ": the camera file is empty"};
  if (text[first] == '{' && (text.find("\"mannequin") != std::string::npos ||
                             text.find("\"mirror") != std::string::npos ||
                             text.find("\"calibration\"") != std::string::npos))
    return Error{path +
                 ": this is a station scene JSON, not a camera file; give an OpenCV "
                 "FileStorage YAML/XML or a ROS camera_info YAML here (pass station files "
                 "with --station)"};
  if (text.find('\0') != std::string::npos)
    return Error{path + ": binary data, not a camera file (expected an OpenCV or ROS YAML)"};

  // In memory, OpenCV detects YAML only by its "%YAML" directive, which ROS files lack.
  std::string body = text;
  if (text[first] != '<' && text[first] != '{' && text.compare(first, 5, "%YAML") != 0)
    body = "%YAML:1.0\n" + text;
  if (text[first] == '<') {
    // OpenCV 4.6's XML parser dereferences past the end on an attribute cut
    // off after '=' (found by fuzzing): check attribute syntax first.
    if (std::string bad = malformed_xml_attribute(text); !bad.empty())
      return Error{path + ": not a readable XML camera file (" + bad +
                   "); expected an OpenCV FileStorage XML"};
    // It also crashes on bare carriage returns inside markup: XML treats CR
    // and CR LF as LF anyway.
    std::string lf;
    lf.reserve(body.size());
    for (std::size_t i = 0; i < body.size(); ++i) {
      if (body[i] != '\r') lf += body[i];
      else if (i + 1 >= body.size() || body[i + 1] != '\n') lf += '\n';
    }
    body.swap(lf);
  }
  cv::FileStorage fs;
  try {
    fs.open(body, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    return Error{path + ": not a readable YAML/XML camera file (" + e.err +
                 "); expected an OpenCV FileStorage or ROS camera_info YAML"};
  } catch (const std::exception& e) {  // OpenCV 4.6 also throws std::length_error (fuzzing)
    return Error{path + ": not a readable YAML/XML camera file (" + e.what() +
                 "); expected an OpenCV FileStorage or ROS camera_info YAML"};
  }
  if (!fs.isOpened())
    return Error{path + ": not a readable YAML/XML camera file; expected an OpenCV FileStorage "
                        "or ROS camera_info YAML"};
  const cv::FileNode root = fs.root();
  if (!root.isMap())
    return Error{path + ": the top level must be a map of fields (camera_matrix, ...)"};

  CameraFile f;
  const bool xml = text.compare(first, 5, "<?xml") == 0 || text[first] == '<';
  const bool ros = !root["distortion_model"].empty() || !root["projection_matrix"].empty() ||
                   !root["camera_name"].empty();
  f.source_format = ros ? "ros-yaml" : (xml ? "opencv-xml" : "opencv-yaml");

  auto need_int = [&](std::initializer_list<const char*> names, int& out) -> std::string {
    cv::FileNode n = find(root, names);
    if (n.empty()) return path + ": missing field " + *names.begin();
    if (!n.isInt()) return path + ": field " + *names.begin() + " must be an integer";
    out = static_cast<int>(n);
    return {};
  };
  if (std::string e = need_int({"image_width", "image_Width"}, f.camera.width); !e.empty())
    return Error{e};
  if (std::string e = need_int({"image_height", "image_Height"}, f.camera.height); !e.empty())
    return Error{e};

  cv::FileNode km = find(root, {"camera_matrix", "Camera_Matrix"});
  if (km.empty())
    return Error{path + ": missing field camera_matrix (is this a camera calibration file?)"};
  std::vector<double> k;
  int rows = 0, cols = 0;
  if (std::string e = read_matrix(km, "camera_matrix", k, rows, cols); !e.empty())
    return Error{path + ": " + e};
  if (rows != 3 || cols != 3) {
    std::ostringstream os;
    os << path << ": camera_matrix is " << rows << "x" << cols << ", must be 3x3";
    return Error{os.str()};
  }
  if (std::abs(k[3]) > 1e-9 || std::abs(k[6]) > 1e-9 || std::abs(k[7]) > 1e-9 ||
      std::abs(k[8] - 1.0) > 1e-9)
    return Error{path + ": camera_matrix must be [fx 0 cx; 0 fy cy; 0 0 1]"};
  if (std::abs(k[1]) > 1e-6 * std::abs(k[0]))
    return Error{path + ": camera_matrix has a skew term; the pinhole model here has none "
                        "(recalibrate with zero skew)"};
  f.camera.fx = k[0];
  f.camera.cx = k[2];
  f.camera.fy = k[4];
  f.camera.cy = k[5];

  if (ros || !root["fisheye_model"].empty()) {
    cv::FileNode fm = root["fisheye_model"];
    if (!fm.empty() && fm.isInt() && static_cast<int>(fm) != 0)
      return Error{path + ": fisheye_model = 1: the fisheye model is not supported; "
                          "recalibrate with the pinhole model"};
  }
  std::string model_name;
  if (cv::FileNode m = root["distortion_model"]; !m.empty()) {
    if (!m.isString()) return Error{path + ": distortion_model must be a string"};
    model_name = static_cast<std::string>(m);
    if (model_name != "plumb_bob" && model_name != "rational_polynomial")
      return Error{path + ": distortion_model \"" + model_name +
                   "\" is not supported (use plumb_bob or rational_polynomial)"};
  }
  if (cv::FileNode m = root["model"]; !m.empty()) {
    if (!m.isString()) return Error{path + ": model must be a string"};
    model_name = static_cast<std::string>(m);
    if (model_name != kModelRadTan5 && model_name != kModelRational8 && model_name != kModelK1 &&
        model_name != kModelK1K2)
      return Error{path + ": model \"" + model_name + "\" is not supported (use " + kModelK1 +
                   ", " + kModelK1K2 + ", " + kModelRadTan5 + " or " + kModelRational8 + ")"};
  }

  cv::FileNode dn = find(root, {"distortion_coefficients", "Distortion_Coefficients", "D"});
  if (dn.empty()) return Error{path + ": missing field distortion_coefficients"};
  if (std::string e = read_matrix(dn, "distortion_coefficients", f.dist, rows, cols); !e.empty())
    return Error{path + ": " + e};
  const std::size_t nd = f.dist.size();
  if (nd != 4 && nd != 5 && nd != 8) {
    std::ostringstream os;
    os << path << ": distortion_coefficients has " << nd
       << " entries; supported are 4 or 5 (k1 k2 p1 p2 [k3]) and 8 (rational model)";
    return Error{os.str()};
  }
  if (nd == 4) f.dist.push_back(0.0);
  const bool rational = f.dist.size() == 8;
  if ((model_name == "plumb_bob" || model_name == kModelRadTan5) && rational)
    return Error{path + ": distortion model " + model_name +
                 " needs 5 distortion_coefficients, the file has 8"};
  if ((model_name == "rational_polynomial" || model_name == kModelRational8) && !rational)
    return Error{path + ": distortion model " + model_name +
                 " needs 8 distortion_coefficients, the file has " + std::to_string(nd)};
  if ((model_name == kModelK1 || model_name == kModelK1K2) && rational)
    return Error{path + ": model " + model_name + " needs 5 distortion_coefficients, the file has 8"};
  f.model = rational ? kModelRational8
                     : (model_name == kModelK1 || model_name == kModelK1K2 ? model_name
                                                                          : std::string(kModelRadTan5));
  if (std::string e = check_model_coefficients(f.model, f.dist); !e.empty())
    return Error{path + ": model: " + e};
  for (int i = 0; i < 5; ++i) f.camera.dist[i] = f.dist[i];
  if (rational && (f.dist[5] != 0 || f.dist[6] != 0 || f.dist[7] != 0))
    f.warning = "rational model: the tracker and renderer use only k1 k2 p1 p2 k3; k4..k6 are "
                "ignored there (recalibrate with the 5-coefficient model for tracking)";

  if (cv::FileNode n = find(root, {"rms_px", "avg_reprojection_error", "Avg_Reprojection_Error"});
      !n.empty()) {
    if (!n.isReal() && !n.isInt()) return Error{path + ": avg_reprojection_error must be a number"};
    f.rms_px = static_cast<double>(n);
  }
  if (cv::FileNode n = root["intrinsics_std_devs"]; !n.empty()) {
    if (std::string e = read_matrix(n, "intrinsics_std_devs", f.std_devs, rows, cols); !e.empty())
      return Error{path + ": " + e};
  }
  auto opt_string = [&](std::initializer_list<const char*> names, std::string& out) {
    cv::FileNode n = find(root, names);
    if (!n.empty() && n.isString()) out = static_cast<std::string>(n);
  };
  opt_string({"date", "calibration_time", "calibration_Time"}, f.date);
  opt_string({"device"}, f.device);
  opt_string({"camera_name"}, f.camera_name);
  if (cv::FileNode n = find(root, {"views_used", "nframes", "nr_of_frames"}); !n.empty() && n.isInt())
    f.views_used = static_cast<int>(n);

  if (std::string e = f.validate(); !e.empty()) return Error{path + ": " + e};
  return f;
}

std::string ext_of(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

std::string check_model_coefficients(const std::string& model, const std::vector<double>& dist) {
  if (model != kModelRadTan5 && model != kModelRational8 && model != kModelK1 && model != kModelK1K2)
    return "model \"" + model + "\" must be " + kModelK1 + ", " + kModelK1K2 + ", " +
           kModelRadTan5 + " or " + kModelRational8;
  const std::size_t want = model == kModelRational8 ? 8 : 5;
  if (dist.size() != want)
    return "model " + model + " needs " + std::to_string(want) + " distortion coefficients, there are " +
           std::to_string(dist.size());
  static const char* names[] = {"k1", "k2", "p1", "p2", "k3"};
  const std::size_t first_zero = model == kModelK1 ? 1 : model == kModelK1K2 ? 2 : 5;
  for (std::size_t i = first_zero; i < 5; ++i)
    if (dist[i] != 0.0) {
      std::ostringstream os;
      os << "model " << model << " has " << names[i] << " = " << dist[i] << ", which that model "
         << "holds at 0; name the model " << kModelRadTan5 << " or recalibrate";
      return os.str();
    }
  return {};
}

std::string CameraFile::validate() const {
  if (std::string e = camera.validate(); !e.empty()) return e;
  if (model != kModelRadTan5 && model != kModelRational8 && model != kModelK1 && model != kModelK1K2)
    return "model \"" + model + "\" must be " + kModelK1 + ", " + kModelK1K2 + ", " + kModelRadTan5 +
           " or " + kModelRational8;
  const std::size_t want = model == kModelRational8 ? 8 : 5;
  if (!dist.empty()) {
    if (dist.size() != want)
      return "dist has " + std::to_string(dist.size()) + " coefficients, model " + model +
             " needs " + std::to_string(want);
    if (std::string e = check_model_coefficients(model, dist); !e.empty()) return "model: " + e;
    for (int i = 0; i < 5; ++i)
      if (dist[i] != camera.dist[i])
        return "dist[" + std::to_string(i) + "] differs from camera.dist[" + std::to_string(i) + "]";
    for (double d : dist)
      if (!std::isfinite(d)) return "dist has a non-finite coefficient";
  }
  if (!std::isfinite(rms_px)) return "rms_px is not finite";
  for (double s : std_devs)
    if (!std::isfinite(s) || s < 0) return "std_devs must be finite and >= 0";
  if (views_used < 0) return "views_used must be >= 0";
  return {};
}

Result<CameraFile> read_camera_file(const std::string& path) {
  std::string err;
  std::string text = read_text(path, err);
  if (!err.empty()) return Error{err};
  return parse(path, text);
}

Status write_camera_file(const std::string& path, const CameraFile& file) {
  if (std::string e = file.validate(); !e.empty())
    return Error{path + ": refusing to write an invalid camera file: " + e};
  const std::string ext = ext_of(path);
  const bool xml = ext == ".xml";
  if (!xml && ext != ".yaml" && ext != ".yml")
    return Error{path + ": camera files end in .yaml, .yml or .xml"};
  std::vector<double> dist = file.dist;
  if (dist.empty()) dist.assign(file.camera.dist.begin(), file.camera.dist.end());
  std::string text;
  try {
    cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY |
                                    (xml ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML));
    fs.writeComment("DentAR camera intrinsics (OpenCV pinhole model; px)");
    // Free text goes through cv::write, which stores it as a string: `fs << key << text` reads
    // a text starting with '{' or '[' as the start of a map or sequence and writes a file
    // OpenCV cannot read back (found by fuzzing: a date "{un Nov 22 ...").
    cv::write(fs, "calibration_time", file.date.empty() ? iso_now_utc() : file.date);
    cv::write(fs, "device", file.device);
    if (!file.camera_name.empty()) cv::write(fs, "camera_name", file.camera_name);
    fs << "image_width" << file.camera.width << "image_height" << file.camera.height;
    fs << "model" << file.model;
    const cv::Matx33d K(file.camera.fx, 0, file.camera.cx, 0, file.camera.fy, file.camera.cy, 0, 0, 1);
    fs << "camera_matrix" << cv::Mat(K);
    fs << "distortion_coefficients" << cv::Mat(1, static_cast<int>(dist.size()), CV_64F, dist.data());
    fs << "avg_reprojection_error" << file.rms_px;
    if (!file.std_devs.empty()) {
      fs.writeComment("std devs of fx fy cx cy k1 k2 p1 p2 k3 [k4 k5 k6]");
      std::vector<double> s = file.std_devs;
      fs << "intrinsics_std_devs" << cv::Mat(1, static_cast<int>(s.size()), CV_64F, s.data());
    }
    fs << "views_used" << file.views_used;
    text = fs.releaseAndGetString();
  } catch (const cv::Exception& e) {
    return Error{path + ": OpenCV could not serialise the camera file: " + e.err};
  }
  return write_text_atomic(path, text);
}

Status write_ros_camera_info(const std::string& path, const CameraFile& file) {
  if (std::string e = file.validate(); !e.empty())
    return Error{path + ": refusing to write an invalid camera file: " + e};
  std::vector<double> dist = file.dist;
  if (dist.empty()) dist.assign(file.camera.dist.begin(), file.camera.dist.end());
  const auto& c = file.camera;
  std::ostringstream os;
  os << std::setprecision(17);
  auto mat = [&](const char* name, int r, int cols, const std::vector<double>& d) {
    os << name << ":\n  rows: " << r << "\n  cols: " << cols << "\n  data: [";
    // Always a decimal point or exponent: YAML reads "12500000000" as an int
    // (and OpenCV wraps it), found by fuzzing.
    for (std::size_t i = 0; i < d.size(); ++i) {
      std::ostringstream v;
      v << std::setprecision(17) << d[i];
      std::string t = v.str();
      if (t.find_first_of(".eEn") == std::string::npos) t += ".0";
      os << (i ? ", " : "") << t;
    }
    os << "]\n";
  };
  os << "image_width: " << c.width << "\nimage_height: " << c.height << "\n";
  // Quoted, so a name such as "{left" or "cam #2" stays a string (unquoted, OpenCV could not
  // read the file back: found by fuzzing); quotes, backslashes and control characters, which
  // OpenCV's YAML reader does not unescape reliably, become '_'.
  std::string name = file.camera_name.empty() ? "dentar_camera" : file.camera_name;
  for (char& ch : name)
    if (ch == '"' || ch == '\\' || static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = '_';
  os << "camera_name: \"" << name << "\"\n";
  mat("camera_matrix", 3, 3, {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1});
  os << "distortion_model: " << (dist.size() == 8 ? "rational_polynomial" : "plumb_bob") << "\n";
  mat("distortion_coefficients", 1, static_cast<int>(dist.size()), dist);
  mat("rectification_matrix", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  mat("projection_matrix", 3, 4, {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0});
  return write_text_atomic(path, os.str());
}

}  // namespace dentar::calibration
