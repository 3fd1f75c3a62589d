// Raw volume + JSON sidecar ("dentar-raw"): the sidecar describes a headerless
// data file. Units in the file are mm; in code metres.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "image_io_internal.h"

namespace dentar::volume {

using detail::file_error;
using nlohmann::json;

namespace {

constexpr int kRawJsonVersion = 1;
// Larger skips are certainly a typo and would overflow size arithmetic.
constexpr std::int64_t kMaxSkipBytes = std::int64_t{1} << 40;

Error field_error(std::string_view name, std::string_view field, std::string_view problem) {
  return file_error(name, "field \"" + std::string(field) + "\": " + std::string(problem));
}

// Reads a 3-vector of finite numbers from j[key] into out (scaled by `scale`).
Status read_vec3(const json& j, const char* key, std::string_view name, double scale,
                 Eigen::Vector3d* out) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_array() || it->size() != 3)
    return field_error(name, key, "must be an array of 3 numbers");
  for (int a = 0; a < 3; ++a) {
    const json& e = (*it)[static_cast<std::size_t>(a)];
    if (!e.is_number()) return field_error(name, key, "must be an array of 3 numbers");
    const double x = e.get<double>();
    if (!std::isfinite(x)) return field_error(name, key, "values must be finite");
    (*out)[a] = x * scale;
  }
  return {};
}

}  // namespace

Result<VolumeHeader> parse_raw_json_header(std::string_view text, std::string_view name) {
  json j;
  try {
    j = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    return file_error(
        name, std::string("invalid JSON at byte ") + std::to_string(e.byte) + ": " + e.what());
  } catch (const std::exception& e) {
    return file_error(name, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) return file_error(name, "the sidecar must be a JSON object");

  // Unknown keys are refused: a misspelt "spacing" (no _mm) must not be ignored.
  static constexpr std::array<std::string_view, 9> kKeys = {"format",    "version", "data",
                                                            "dims",      "type",    "spacing_mm",
                                                            "origin_mm", "endian",  "header_bytes"};
  for (const auto& [k, unused] : j.items()) {
    if (std::find(kKeys.begin(), kKeys.end(), k) == kKeys.end())
      return field_error(name, k,
                         "unknown key (allowed: format, version, data, dims, type, spacing_mm, "
                         "origin_mm, endian, header_bytes)");
  }
  const auto fmt = j.find("format");
  if (fmt == j.end() || !fmt->is_string() || fmt->get<std::string>() != "dentar-raw")
    return field_error(name, "format", "must be \"dentar-raw\"");
  const auto ver = j.find("version");
  if (ver == j.end() || !ver->is_number_integer() || ver->get<std::int64_t>() != kRawJsonVersion)
    return field_error(name, "version", "must be 1 (the only version this reader knows)");

  VolumeHeader h;
  const auto data = j.find("data");
  if (data == j.end() || !data->is_string() || data->get<std::string>().empty())
    return field_error(name, "data", "must name the raw data file (relative to the sidecar)");
  h.data_file = detail::resolve_beside(name, data->get<std::string>());

  const auto dims = j.find("dims");
  if (dims == j.end() || !dims->is_array() || dims->size() != 3)
    return field_error(name, "dims", "must be an array of 3 integers");
  for (int a = 0; a < 3; ++a) {
    const json& e = (*dims)[static_cast<std::size_t>(a)];
    if (!e.is_number_integer()) return field_error(name, "dims", "must be an array of 3 integers");
    const std::int64_t d = e.get<std::int64_t>();
    if (d < 1 || d > kMaxDim)
      return field_error(name, "dims",
                         "dims[" + std::to_string(a) + "] = " + std::to_string(d) +
                             " is outside [1, " + std::to_string(kMaxDim) + "]");
    h.geometry.dims[a] = static_cast<int>(d);
  }

  const auto type = j.find("type");
  if (type == j.end() || !type->is_string())
    return field_error(name, "type",
                       "missing (uint8, int8, uint16, int16, uint32, int32, "
                       "float32 or float64)");
  const auto t = detail::element_type_from_name(type->get<std::string>());
  if (!t)
    return field_error(name, "type",
                       "unknown element type \"" + type->get<std::string>() +
                           "\" (uint8, int8, uint16, int16, uint32, int32, float32, float64)");
  h.type = *t;

  if (auto s = read_vec3(j, "spacing_mm", name, 1e-3, &h.geometry.spacing); !s)
    return Error{s.error()};
  for (int a = 0; a < 3; ++a)
    if (!(h.geometry.spacing[a] > 0)) return field_error(name, "spacing_mm", "values must be > 0");
  h.geometry.origin.setZero();
  if (j.contains("origin_mm")) {
    if (auto s = read_vec3(j, "origin_mm", name, 1e-3, &h.geometry.origin); !s)
      return Error{s.error()};
  }

  if (const auto e = j.find("endian"); e != j.end()) {
    if (!e->is_string() || (*e != "little" && *e != "big"))
      return field_error(name, "endian", "must be \"little\" or \"big\"");
    h.big_endian = *e == "big";
  }
  if (const auto hb = j.find("header_bytes"); hb != j.end()) {
    if (!hb->is_number_integer() || hb->get<std::int64_t>() < 0 ||
        hb->get<std::int64_t>() > kMaxSkipBytes)
      return field_error(name, "header_bytes", "must be an integer in [0, 2^40]");
    h.data_offset = static_cast<std::size_t>(hb->get<std::int64_t>());
  }
  if (auto s = detail::validate_geometry(h.geometry, name); !s) return Error{s.error()};
  return h;
}

Result<ImageVolume> load_raw_json(const std::string& json_path) {
  // The sidecar holds no data, so "header" = whole file; the parser signature
  // with header_bytes is shared with the other formats.
  return detail::load_with_parser(
      json_path, [](std::string_view text, std::string_view name, std::size_t* hb) {
        if (hb) *hb = text.size();
        if (text.size() >= kMaxHeaderBytes)
          return Result<VolumeHeader>(file_error(name, "sidecar is larger than 1 MiB"));
        return parse_raw_json_header(text, name);
      });
}

Status write_raw_json(const ImageVolume& v, const std::string& json_path, const WriteOptions& o) {
  if (o.gzip) return file_error(json_path, "the raw format has no gzip encoding");
  if (auto s = detail::validate_geometry(v.geometry, json_path); !s) return s;
  auto bytes = detail::encode_values(v, o.big_endian, json_path);
  if (!bytes) return Error{bytes.error()};
  const std::string data_name = detail::stem_of(json_path) + ".raw";
  json j;
  j["format"] = "dentar-raw";
  j["version"] = kRawJsonVersion;
  j["data"] = data_name;
  j["dims"] = {v.geometry.dims.x(), v.geometry.dims.y(), v.geometry.dims.z()};
  j["type"] = std::string(element_type_name(v.source_type));
  const Eigen::Vector3d s = v.geometry.spacing * 1e3, org = v.geometry.origin * 1e3;
  j["spacing_mm"] = {s.x(), s.y(), s.z()};
  j["origin_mm"] = {org.x(), org.y(), org.z()};
  j["endian"] = o.big_endian ? "big" : "little";
  j["header_bytes"] = 0;
  const std::string text = j.dump(2) + "\n";
  if (auto st = detail::write_file_bytes(detail::resolve_beside(json_path, data_name), *bytes); !st)
    return st;
  return detail::write_file_bytes(
      json_path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

}  // namespace dentar::volume
