#include "dentar/training/exercise.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dentar/volume/procedural_incisor.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::training {
namespace {

using nlohmann::json;
using volume::kIsoDensity;

struct Ctx {
  std::string file;
  std::string err;
  bool fail(const std::string& field, const std::string& what) {
    if (err.empty()) err = file + ": field '" + field + "': " + what;
    return false;
  }
};

bool get_number(Ctx& c, const json& j, const std::string& key, const std::string& path, double& out,
                bool required, double lo = -1e9, double hi = 1e9) {
  if (!j.contains(key)) return required ? c.fail(path + key, "missing (a number)") : true;
  const json& v = j.at(key);
  if (!v.is_number()) return c.fail(path + key, "must be a number");
  out = v.get<double>();
  if (!std::isfinite(out) || out < lo || out > hi) {
    std::ostringstream os;
    os << "value " << out << " outside [" << lo << ", " << hi << "]";
    return c.fail(path + key, os.str());
  }
  return true;
}

bool get_string(Ctx& c, const json& j, const std::string& key, const std::string& path,
                std::string& out, bool required) {
  if (!j.contains(key)) return required ? c.fail(path + key, "missing (a string)") : true;
  if (!j.at(key).is_string()) return c.fail(path + key, "must be a string");
  out = j.at(key).get<std::string>();
  return true;
}

// The rubric's bands shared by outline_extension and floor_depth: ideal / acceptable /
// modification in mm at the file (m in T), with their grades. `strict`: the top band must be
// wider than the ideal one (continuous grading divides by their difference). Empty: ok.
template <class T>
std::string read_bands(Ctx& c, const json& w, const std::string& name, const std::string& path, T& t, bool strict) {
  double ideal = 0.25, acc = 0.5, mod = 1.0;
  if (!get_number(c, w, "ideal_mm", path, ideal, false, 0, 10) ||
      !get_number(c, w, "acceptable_mm", path, acc, false, 0, 10) ||
      !get_number(c, w, "modification_mm", path, mod, false, 0, 10) ||
      !get_number(c, w, "accept_fraction", path, t.accept_fraction, false, 0, 1) ||
      !get_number(c, w, "modify_fraction", path, t.modify_fraction, false, 0, 1))
    return c.err;
  if (!(ideal <= acc && acc <= mod) || (strict && mod <= ideal))
    return name + ": fields '" + path + "ideal_mm' / 'acceptable_mm' / 'modification_mm': must not decrease (" +
           std::to_string(ideal) + ", " + std::to_string(acc) + ", " + std::to_string(mod) + ")";
  t.ideal_m = ideal * 1e-3;
  t.acceptable_m = acc * 1e-3;
  t.modification_m = mod * 1e-3;
  return "";
}

// A form criterion's coverage share (session 22): "coverage_full_pct" and "coverage_share".
template <class T>
bool read_coverage_share(Ctx& c, const json& w, const std::string& name, const std::string& path, T& t, std::string& err) {
  if (!get_number(c, w, "coverage_full_pct", path, t.coverage_full_pct, false, 0, 100)) return false;
  std::string mode = "scale";
  if (!get_string(c, w, "coverage_share", path, mode, false)) return false;
  if (mode != "scale" && mode != "cap") {
    err = name + ": field '" + path + "coverage_share': '" + mode +
          "' is not a rule (\"scale\", the default: points x the coverage share; \"cap\": at most that)";
    return false;
  }
  if (w.contains("coverage_share") && t.coverage_full_pct <= 0) {
    err = name + ": field '" + path + "coverage_share': needs '" + path + "coverage_full_pct' above 0";
    return false;
  }
  t.coverage_cap = mode == "cap";
  return true;
}

// A criterion's `from_region`: a target region of the exercise, or an error naming the field.
const Region* target_region(const Exercise& ex, const std::string& name, const std::string& path,
                            const std::string& region, std::string& err) {
  const Region* r = ex.region(region);
  if (!r || r->role != RegionRole::kTarget)
    err = name + ": field '" + path + "from_region': '" + region + "' is not a target region of this exercise";
  return err.empty() ? r : nullptr;
}

bool get_vec3_mm(Ctx& c, const json& j, const std::string& key, const std::string& path,
                 Eigen::Vector3d& out_m, double scale = 1e-3) {
  if (!j.contains(key)) return c.fail(path + key, "missing (an array of 3 numbers)");
  const json& v = j.at(key);
  if (!v.is_array() || v.size() != 3) return c.fail(path + key, "must be an array of 3 numbers");
  for (int i = 0; i < 3; ++i) {
    if (!v[static_cast<std::size_t>(i)].is_number())
      return c.fail(path + key + "[" + std::to_string(i) + "]", "must be a number");
    const double x = v[static_cast<std::size_t>(i)].get<double>();
    if (!std::isfinite(x) || std::abs(x) > 1e4)
      return c.fail(path + key + "[" + std::to_string(i) + "]", "must be finite and below 1e4");
    out_m[i] = x * scale;
  }
  return true;
}

bool parse_material(Ctx& c, const std::string& s, const std::string& field, volume::Material& m) {
  for (int i = 0; i < volume::kNumMaterials; ++i)
    if (volume::material_name(static_cast<volume::Material>(i)) == s) {
      m = static_cast<volume::Material>(i);
      return true;
    }
  return c.fail(field, "unknown material '" + s + "' (enamel, dentin, pulp, caries, restoration)");
}

bool parse_primitive(Ctx& c, const json& j, const std::string& path, Primitive& p) {
  if (!j.is_object()) return c.fail(path, "must be an object");
  std::string shape;
  if (!get_string(c, j, "shape", path + ".", shape, true)) return false;
  if (j.contains("not")) {
    if (!j["not"].is_boolean()) return c.fail(path + ".not", "must be true or false");
    p.negate = j["not"].get<bool>();
  }
  const std::string pp = path + ".";
  if (shape == "sphere") {
    p.kind = PrimitiveKind::kSphere;
    if (!get_vec3_mm(c, j, "center_mm", pp, p.a_m)) return false;
    double r = 0;
    if (!get_number(c, j, "radius_mm", pp, r, true, 1e-3, 1e3)) return false;
    p.radius_m = r * 1e-3;
  } else if (shape == "box") {
    p.kind = PrimitiveKind::kBox;
    if (!get_vec3_mm(c, j, "min_mm", pp, p.a_m) || !get_vec3_mm(c, j, "max_mm", pp, p.b_m))
      return false;
    if ((p.b_m - p.a_m).minCoeff() <= 0) return c.fail(pp + "max_mm", "must exceed min_mm on every axis");
  } else if (shape == "cylinder") {
    p.kind = PrimitiveKind::kCylinder;
    if (!get_vec3_mm(c, j, "from_mm", pp, p.a_m) || !get_vec3_mm(c, j, "to_mm", pp, p.b_m)) return false;
    if ((p.b_m - p.a_m).norm() < 1e-6) return c.fail(pp + "to_mm", "must differ from from_mm");
    double r = 0;
    if (!get_number(c, j, "radius_mm", pp, r, true, 1e-3, 1e3)) return false;
    p.radius_m = r * 1e-3;
  } else if (shape == "halfspace") {
    p.kind = PrimitiveKind::kHalfSpace;
    if (!get_vec3_mm(c, j, "point_mm", pp, p.a_m) || !get_vec3_mm(c, j, "normal", pp, p.b_m, 1.0))
      return false;
    if (p.b_m.norm() < 1e-9) return c.fail(pp + "normal", "must not be zero");
    p.b_m.normalize();
  } else if (shape == "material") {
    p.kind = PrimitiveKind::kMaterial;
    std::string m;
    if (!get_string(c, j, "material", pp, m, true)) return false;
    if (!parse_material(c, m, pp + "material", p.material)) return false;
  } else if (shape == "shell") {
    p.kind = PrimitiveKind::kShell;
    double d = 0;
    if (!get_number(c, j, "depth_mm", pp, d, true, 1e-3, 50)) return false;
    p.depth_m = d * 1e-3;
  } else if (shape == "solid") {
    p.kind = PrimitiveKind::kSolid;
  } else {
    return c.fail(pp + "shape", "unknown shape '" + shape +
                                    "' (sphere, box, cylinder, halfspace, material, shell, solid)");
  }
  return true;
}

}  // namespace

bool Primitive::contains(const Eigen::Vector3d& p, double grow) const {
  bool in = true;
  switch (kind) {
    case PrimitiveKind::kSphere: in = (p - a_m).norm() <= radius_m + grow; break;
    case PrimitiveKind::kBox:
      in = (p.array() >= a_m.array() - grow).all() && (p.array() <= b_m.array() + grow).all();
      break;
    case PrimitiveKind::kCylinder: {
      const Eigen::Vector3d ax = b_m - a_m;
      const double len = ax.norm();
      const double t = (p - a_m).dot(ax) / len;
      const double r = (p - a_m - ax * (t / len)).norm();
      in = t >= -grow && t <= len + grow && r <= radius_m + grow;
      break;
    }
    case PrimitiveKind::kHalfSpace: in = (p - a_m).dot(b_m) <= grow; break;
    default: in = true; break;  // volume-based kinds: decided by build_masks
  }
  return negate ? !in : in;
}

const Region* Exercise::region(const std::string& n) const {
  for (const auto& r : regions)
    if (r.name == n) return &r;
  return nullptr;
}

double Exercise::max_points() const {
  if (outcome == OutcomeKind::kAccessOpening) return 18.0;
  double s = 0;
  for (const auto& r : regions) s += r.points;
  if (wall_taper) s += wall_taper->points;
  return s;
}

double Exercise::pulp_exposure_size_mm(double pulp_mm3) {
  return pulp_mm3 > 0 ? 2.0 * std::cbrt(3.0 * pulp_mm3 / (2.0 * M_PI)) : 0.0;
}

double Exercise::pulp_exposure_charge(double pulp_mm3) const {
  if (pulp_mm3 <= 0) return 0.0;
  const double full = pulp_exposure_points();
  if (pulp_exposure_full_mm <= 0) return full;
  const double f = std::min(1.0, pulp_exposure_size_mm(pulp_mm3) / pulp_exposure_full_mm);
  return full * std::min(1.0, pulp_exposure_min_fraction + (1.0 - pulp_exposure_min_fraction) * f);
}

Result<Exercise> parse_exercise(const std::string& text, const std::string& name) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) {
    // Find the failing byte offset for the message.
    try {
      const json again = json::parse(text);
      (void)again;
    } catch (const json::exception& e) {  // parse_error, or out_of_range for a number overflow
      std::size_t line = 1, col = 1;
      std::size_t byte = text.size();
      if (const auto* pe = dynamic_cast<const json::parse_error*>(&e)) byte = pe->byte > 0 ? pe->byte - 1 : 0;
      for (std::size_t i = 0; i < std::min(byte, text.size()); ++i) {
        if (text[i] == '\n') {
          ++line;
          col = 1;
        } else {
          ++col;
        }
      }
      if (!dynamic_cast<const json::parse_error*>(&e)) return Error{name + ": not valid JSON (" + e.what() + ")"};
      return Error{name + ": line " + std::to_string(line) + ", column " + std::to_string(col) +
                   ": not valid JSON (" + e.what() + ")"};
    }
    return Error{name + ": not valid JSON"};
  }
  Ctx c{name, {}};
  Exercise ex;
  ex.source = name;
  if (!j.is_object()) return Error{name + ": the exercise must be a JSON object"};
  std::string fmt;
  if (!get_string(c, j, "format", "", fmt, true)) return Error{c.err};
  if (fmt != "dentar-exercise") return Error{name + ": field 'format': must be \"dentar-exercise\""};
  double version = 0;
  if (!get_number(c, j, "version", "", version, true, 1, 1)) return Error{c.err};
  if (!get_string(c, j, "name", "", ex.name, true) || !get_string(c, j, "title", "", ex.title, false) ||
      !get_string(c, j, "procedure", "", ex.procedure, true))
    return Error{c.err};
  if (!j.contains("tooth") || !j["tooth"].is_object())
    return Error{name + ": field 'tooth': missing (an object {\"kind\": \"molar\"|\"incisor\", \"voxel_mm\": ...})"};
  {
    const json& t = j["tooth"];
    std::string kind;
    if (!get_string(c, t, "kind", "tooth.", kind, true)) return Error{c.err};
    if (kind != "molar" && kind != "incisor")
      return Error{name + ": field 'tooth.kind': unknown tooth '" + kind + "' (molar, incisor)"};
    double vox = 0.1;
    if (!get_number(c, t, "voxel_mm", "tooth.", vox, false, 0.02, 0.5)) return Error{c.err};
    json tj{{"kind", kind}, {"voxel_mm", vox}};
    if (t.contains("pulp_roof_mm")) {  // the molar's pulp chamber roof above the cervical line (issue 25, session 17)
      if (kind != "molar") return Error{name + ": field 'tooth.pulp_roof_mm': only a molar has it"};
      double roof = 0;
      if (!get_number(c, t, "pulp_roof_mm", "tooth.", roof, true, 0.0, 6.0)) return Error{c.err};
      tj["pulp_roof_mm"] = roof;
    }
    ex.tooth_json = tj.dump();
  }
  if (!j.contains("bur") || !j["bur"].is_object()) return Error{name + ": field 'bur': missing (an object)"};
  {
    const json& b = j["bur"];
    std::string shape;
    if (!get_string(c, b, "shape", "bur.", shape, true)) return Error{c.err};
    auto s = volume::parse_bur_shape(shape);
    if (!s) return Error{name + ": field 'bur.shape': " + s.error()};
    double r = 0.5, len = 3.0, tip = 0.2, samples = 2000;
    if (!get_number(c, b, "radius_mm", "bur.", r, true, 0.05, 5) ||
        !get_number(c, b, "length_mm", "bur.", len, false, 0.1, 30) ||
        !get_number(c, b, "tip_radius_mm", "bur.", tip, false, 0, 5) ||
        !get_number(c, b, "samples", "bur.", samples, false, volume::kMinBurSamples, volume::kMaxBurSamples))
      return Error{c.err};
    switch (*s) {
      case volume::BurShape::kSphere: ex.bur = volume::BurParams::sphere(r); break;
      case volume::BurShape::kCylinder: ex.bur = volume::BurParams::cylinder(r, len); break;
      case volume::BurShape::kCapsule: ex.bur = volume::BurParams::capsule(r, len); break;
      case volume::BurShape::kCone: ex.bur = volume::BurParams::cone(tip, r, len); break;
    }
    if (const std::string why = ex.bur.validate(); !why.empty()) return Error{name + ": field 'bur': " + why};
    ex.bur_samples = static_cast<int>(samples);
  }
  if (!get_number(c, j, "time_limit_s", "", ex.time_limit_s, true, 1, 36000) ||
      !get_number(c, j, "excessive_force_N", "", ex.excessive_force_N, false, 0.1, 50))
    return Error{c.err};
  if (!j.contains("regions") || !j["regions"].is_array() || j["regions"].empty())
    return Error{name + ": field 'regions': missing (a non-empty array)"};
  if (j["regions"].size() > 32) return Error{name + ": field 'regions': at most 32 regions"};
  for (std::size_t i = 0; i < j["regions"].size(); ++i) {
    const json& rj = j["regions"][i];
    const std::string path = "regions[" + std::to_string(i) + "].";
    if (!rj.is_object()) return Error{name + ": field 'regions[" + std::to_string(i) + "]': must be an object"};
    Region r;
    std::string role;
    if (!get_string(c, rj, "name", path, r.name, true) || !get_string(c, rj, "role", path, role, true))
      return Error{c.err};
    if (ex.region(r.name)) return Error{name + ": field '" + path + "name': duplicate region '" + r.name + "'"};
    if (role == "target") r.role = RegionRole::kTarget;
    else if (role == "forbidden") r.role = RegionRole::kForbidden;
    else if (role == "entry") r.role = RegionRole::kEntry;
    else return Error{name + ": field '" + path + "role': unknown role '" + role + "' (target, forbidden, entry)"};
    if (!get_number(c, rj, "points", path, r.points, false, 0, 100) ||
        !get_number(c, rj, "zone_mm", path, r.zone_mm, false, 0, 20))
      return Error{c.err};
    if (!rj.contains("all") || !rj["all"].is_array() || rj["all"].empty())
      return Error{name + ": field '" + path + "all': missing (a non-empty array of shapes)"};
    for (std::size_t k = 0; k < rj["all"].size(); ++k) {
      Primitive p;
      if (!parse_primitive(c, rj["all"][k], path + "all[" + std::to_string(k) + "]", p)) return Error{c.err};
      r.all.push_back(p);
    }
    ex.regions.push_back(std::move(r));
  }
  if (!j.contains("steps") || !j["steps"].is_array() || j["steps"].empty())
    return Error{name + ": field 'steps': missing (a non-empty array)"};
  for (std::size_t i = 0; i < j["steps"].size(); ++i) {
    const json& sj = j["steps"][i];
    const std::string path = "steps[" + std::to_string(i) + "].";
    ExerciseStep s;
    if (!sj.is_object()) return Error{name + ": field 'steps[" + std::to_string(i) + "]': must be an object"};
    if (!get_string(c, sj, "name", path, s.name, true) || !get_string(c, sj, "region", path, s.region, false))
      return Error{c.err};
    if (sj.contains("focus_mm")) {
      Eigen::Vector3d f;
      if (!get_vec3_mm(c, sj, "focus_mm", path, f)) return Error{c.err};
      s.focus_m = f;
    }
    if (sj.contains("approach")) {
      Eigen::Vector3d a;
      if (!get_vec3_mm(c, sj, "approach", path, a, 1.0)) return Error{c.err};
      if (a.norm() < 1e-9) return Error{name + ": field '" + path + "approach': must not be zero"};
      s.approach = a.normalized();
    }
    if (!s.region.empty() && !ex.region(s.region))
      return Error{name + ": field '" + path + "region': no region named '" + s.region + "'"};
    ex.steps.push_back(s);
  }
  if (j.contains("outcome")) {
    const json& o = j["outcome"];
    std::string kind;
    if (!o.is_object()) return Error{name + ": field 'outcome': must be an object"};
    if (!get_string(c, o, "kind", "outcome.", kind, true)) return Error{c.err};
    if (kind == "graded_regions") {
      ex.outcome = OutcomeKind::kGradedRegions;
    } else if (kind == "access_opening") {
      ex.outcome = OutcomeKind::kAccessOpening;
      AccessGeometry a;
      if (!o.contains("orifices") || !o["orifices"].is_array() || o["orifices"].empty())
        return Error{name + ": field 'outcome.orifices': missing (a non-empty array)"};
      for (std::size_t i = 0; i < o["orifices"].size(); ++i) {
        const std::string path = "outcome.orifices[" + std::to_string(i) + "].";
        Orifice f;
        if (!get_string(c, o["orifices"][i], "name", path, f.name, true) ||
            !get_vec3_mm(c, o["orifices"][i], "position_mm", path, f.position_m))
          return Error{c.err};
        if (o["orifices"][i].contains("canal_axis")) {
          Eigen::Vector3d ax;
          if (!get_vec3_mm(c, o["orifices"][i], "canal_axis", path, ax, 1.0)) return Error{c.err};
          if (!(ax.norm() > 1e-9) || !(ax.normalized().z() > 0.1))
            return Error{name + ": field '" + path + "canal_axis': must point toward occlusal (a direction with z > 0.1 "
                         "after normalising; the axis from the orifice up the straight-line path), got [" +
                         std::to_string(ax.x()) + ", " + std::to_string(ax.y()) + ", " + std::to_string(ax.z()) + "]"};
          f.canal_axis = ax.normalized();
        }
        a.orifices.push_back(f);
      }
      double oz = 0, fz = 0;
      if (!get_vec3_mm(c, o, "axis_point_mm", "outcome.", a.axis_point_m) ||
          !get_number(c, o, "opening_z_mm", "outcome.", oz, true, -100, 100) ||
          !get_number(c, o, "floor_z_mm", "outcome.", fz, true, -100, 100) ||
          !get_number(c, o, "sight_cone_deg", "outcome.", a.sight_cone_deg, false, 0, 60))
        return Error{c.err};
      double wz = fz;
      if (!get_number(c, o, "walls_from_z_mm", "outcome.", wz, false, fz, oz)) return Error{c.err};
      a.walls_from_z_m = wz * 1e-3;
      if (fz >= oz) return Error{name + ": field 'outcome.floor_z_mm': must be below opening_z_mm"};
      a.opening_z_m = oz * 1e-3;
      a.floor_z_m = fz * 1e-3;
      ex.access = a;
    } else {
      return Error{name + ": field 'outcome.kind': unknown kind '" + kind + "' (graded_regions, access_opening)"};
    }
    if (!get_number(c, o, "pulp_exposure_points", "outcome.", ex.pulp_exposure_cost, false, 0, 1000) ||
        !get_number(c, o, "perforation_points", "outcome.", ex.perforation_cost, false, 0, 1000) ||
        !get_number(c, o, "complete_coverage_pct", "outcome.", ex.complete_coverage_pct, false, 0, 100) ||
        !get_number(c, o, "complete_orifice_sight", "outcome.", ex.complete_orifice_sight, false, 0, 1) ||
        !get_number(c, o, "over_reduction_rate", "outcome.", ex.over_reduction_rate, false, 0, 100) ||
        !get_number(c, o, "tolerance_mm", "outcome.", ex.tolerance_mm, false, 0, 5) ||
        !get_number(c, o, "access_zone_rate", "outcome.", ex.access_zone_rate, false, 0, 100) ||
        !get_number(c, o, "access_zone_free_mm", "outcome.", ex.access_zone_free_mm, false, 0, 5) ||
        !get_number(c, o, "wall_overextension_points_per_mm", "outcome.", ex.wall_overextension_points_per_mm, false, 0, 100) ||
        !get_number(c, o, "wall_overextension_free_mm", "outcome.", ex.wall_overextension_free_mm, false, 0, 5) ||
        !get_number(c, o, "wall_overextension_percentile", "outcome.", ex.wall_overextension_percentile, false, 50, 100) ||
        !get_number(c, o, "under_extension_rate", "outcome.", ex.under_extension_rate, false, 0, 100) ||
        !get_number(c, o, "under_extension_full_pct", "outcome.", ex.under_extension_full_pct, false, 0, 100) ||
        !get_number(c, o, "floor_overflow_rate", "outcome.", ex.floor_overflow_rate, false, 0, 100) ||
        !get_number(c, o, "pulp_exposure_full_mm", "outcome.", ex.pulp_exposure_full_mm, false, 0, 20) ||
        !get_number(c, o, "pulp_exposure_min_fraction", "outcome.", ex.pulp_exposure_min_fraction, false, 0, 1))
      return Error{c.err};
    if (o.contains("pulp_exposure_min_fraction") && ex.pulp_exposure_full_mm <= 0)
      return Error{name + ": field 'outcome.pulp_exposure_min_fraction': needs 'outcome.pulp_exposure_full_mm' above 0 "
                   "(the exposure size that costs the whole pulp_exposure_points); without it every exposure costs "
                   "all of them"};
    if (o.contains("overprep_price")) {
      const auto& v = o["overprep_price"];
      const std::string pv = v.is_string() ? v.get<std::string>() : v.dump();
      if (pv != "exercise" && pv != "region")
        return Error{name + ": field 'outcome.overprep_price': '" + pv +
                     "' is not a price rule (\"region\": each region's points per mm3 of that region, the default; "
                     "\"exercise\": the exercise's points per mm3 of target in every region)"};
      ex.overprep_exercise_price = pv == "exercise";
    }
    if (o.contains("overflow_cost")) {
      if (!o["overflow_cost"].is_boolean())
        return Error{name + ": field 'outcome.overflow_cost': must be true or false"};
      if (ex.outcome != OutcomeKind::kGradedRegions)
        return Error{name + ": field 'outcome.overflow_cost': only a graded_regions outcome takes it"};
      ex.overflow_cost = o["overflow_cost"].get<bool>();
    }
    if (o.contains("access_points")) {
      const auto& v = o["access_points"];
      const std::string pv = v.is_string() ? v.get<std::string>() : v.dump();
      if (pv != "bands" && pv != "continuous")
        return Error{name + ": field 'outcome.access_points': '" + pv +
                     "' is not a rule (\"bands\": each criterion 0, 1, 2 or 3, the default; \"continuous\": points "
                     "falling linearly with the measured deviation)"};
      if (ex.outcome != OutcomeKind::kAccessOpening)
        return Error{name + ": field 'outcome.access_points': only an access_opening outcome has these criteria"};
      ex.access_points = pv == "continuous" ? AccessPoints::kContinuous : AccessPoints::kBands;
    }
    if ((o.contains("flare_free_deg") || o.contains("flare_deg_per_point")) && ex.outcome != OutcomeKind::kAccessOpening)
      return Error{name + ": fields 'outcome.flare_free_deg' / 'outcome.flare_deg_per_point': only an access_opening "
                   "outcome grades its walls' flare"};
    if (!get_number(c, o, "flare_free_deg", "outcome.", ex.access_flare_free_deg, false, 0, 90) ||
        !get_number(c, o, "flare_deg_per_point", "outcome.", ex.access_flare_deg_per_point, false, 0.1, 90))
      return Error{c.err};
    if (o.contains("wall_taper")) {
      const json& w = o["wall_taper"];
      const std::string path = "outcome.wall_taper.";
      if (!w.is_object()) return Error{name + ": field 'outcome.wall_taper': must be an object"};
      if (ex.outcome != OutcomeKind::kGradedRegions)
        return Error{name + ": field 'outcome.wall_taper': only a graded_regions outcome takes it (the access "
                     "opening grades its walls itself)"};
      WallTaper t;
      double fz = 0, tz = 0;
      if (!get_number(c, w, "points", path, t.points, true, 0, 1000) ||
          !get_vec3_mm(c, w, "axis_point_mm", path, t.axis_point_m) ||
          !get_number(c, w, "from_z_mm", path, fz, true, -100, 100) ||
          !get_number(c, w, "to_z_mm", path, tz, true, -100, 100) ||
          !get_number(c, w, "ideal_min_deg", path, t.ideal_min_deg, false, -45, 45) ||
          !get_number(c, w, "ideal_max_deg", path, t.ideal_max_deg, false, -45, 45) ||
          !get_number(c, w, "zero_beyond_deg", path, t.zero_beyond_deg, false, 0.1, 90) ||
          !get_number(c, w, "outline_reach_full_pct", path, t.outline_reach_full_pct, false, 0, 100))
        return Error{c.err};
      if (std::string e; !read_coverage_share(c, w, name, path, t, e)) return Error{e.empty() ? c.err : e};
      if (tz <= fz) return Error{name + ": field 'outcome.wall_taper.to_z_mm': must be above from_z_mm"};
      if (t.ideal_max_deg < t.ideal_min_deg)
        return Error{name + ": field 'outcome.wall_taper.ideal_max_deg': must not be below ideal_min_deg"};
      t.from_z_m = fz * 1e-3;
      t.to_z_m = tz * 1e-3;
      ex.wall_taper = t;
    }
    if (o.contains("outline_extension")) {
      const json& w = o["outline_extension"];
      const std::string path = "outcome.outline_extension.";
      if (!w.is_object()) return Error{name + ": field 'outcome.outline_extension': must be an object"};
      if (ex.outcome != OutcomeKind::kGradedRegions)
        return Error{name + ": field 'outcome.outline_extension': only a graded_regions outcome takes it"};
      OutlineExtension t;
      double fz = 0, tz = 0, margin = 0.5;
      if (!get_number(c, w, "points", path, t.points, true, 0, 1000) ||
          !get_string(c, w, "from_region", path, t.from_region, true) ||
          !get_vec3_mm(c, w, "axis_point_mm", path, t.axis_point_m) ||
          !get_number(c, w, "from_z_mm", path, fz, true, -100, 100) ||
          !get_number(c, w, "to_z_mm", path, tz, true, -100, 100) ||
          !get_number(c, w, "end_margin_mm", path, margin, false, 0, 10))
        return Error{c.err};
      std::string price = "region";
      if (!get_string(c, w, "overprep_price", path, price, false)) return Error{c.err};
      if (price != "region" && price != "coverage")
        return Error{name + ": field 'outcome.outline_extension.overprep_price': '" + price +
                     "' is not a price (\"region\", the default, or \"coverage\")"};
      t.price_follows_coverage = price == "coverage";
      if (tz <= fz) return Error{name + ": field 'outcome.outline_extension.to_z_mm': must be above from_z_mm"};
      std::string err = read_bands(c, w, name, path, t, false);
      const Region* r = err.empty() ? target_region(ex, name, path, t.from_region, err) : nullptr;
      if (!err.empty()) return Error{err};
      if (r->points < t.points)
        return Error{name + ": field 'outcome.outline_extension.points': " + std::to_string(t.points) +
                     " is more than region '" + t.from_region + "' has (" + std::to_string(r->points) + ")"};
      t.from_z_m = fz * 1e-3;
      t.to_z_m = tz * 1e-3;
      t.end_margin_m = margin * 1e-3;
      ex.outline_extension = t;
    }
    if (o.contains("floor_depth")) {
      const json& w = o["floor_depth"];
      const std::string path = "outcome.floor_depth.";
      if (!w.is_object()) return Error{name + ": field 'outcome.floor_depth': must be an object"};
      if (ex.outcome != OutcomeKind::kGradedRegions)
        return Error{name + ": field 'outcome.floor_depth': only a graded_regions outcome takes it"};
      FloorDepth t;
      double margin = 0.5;
      if (!get_number(c, w, "points", path, t.points, true, 0, 1000) ||
          !get_string(c, w, "from_region", path, t.from_region, true) ||
          !get_number(c, w, "margin_mm", path, margin, false, 0, 10))
        return Error{c.err};
      std::string grading = "bands";
      if (!get_string(c, w, "grading", path, grading, false)) return Error{c.err};
      if (grading != "bands" && grading != "continuous")
        return Error{name + ": field 'outcome.floor_depth.grading': '" + grading +
                     "' is not a grading (\"bands\", the default, or \"continuous\")"};
      t.continuous = grading == "continuous";
      if (std::string e; !read_coverage_share(c, w, name, path, t, e)) return Error{e.empty() ? c.err : e};
      std::string err = read_bands(c, w, name, path, t, t.continuous);
      const Region* r = err.empty() ? target_region(ex, name, path, t.from_region, err) : nullptr;
      if (!err.empty()) return Error{err};
      const double oe = ex.outline_extension && ex.outline_extension->from_region == t.from_region
                            ? ex.outline_extension->points : 0.0;
      if (r->points < t.points + oe)
        return Error{name + ": field 'outcome.floor_depth.points': " + std::to_string(t.points) +
                     (oe > 0 ? " and the outline extension's " + std::to_string(oe) + " are" : " is") +
                     " more than region '" + t.from_region + "' has (" + std::to_string(r->points) + ")"};
      t.margin_m = margin * 1e-3;
      ex.floor_depth = t;
    }
  }
  bool any_target = false;
  for (const auto& r : ex.regions) any_target |= r.role == RegionRole::kTarget;
  if (!any_target) return Error{name + ": field 'regions': no region has role \"target\""};
  return ex;
}

Result<Exercise> load_exercise(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return Error{path + ": cannot open the exercise file (does it exist?)"};
  std::ostringstream ss;
  ss << f.rdbuf();
  if (ss.str().size() > (1u << 20)) return Error{path + ": exercise file over 1 MiB"};
  return parse_exercise(ss.str(), path);
}

// DENTAR_ASSETS, else the source tree's assets (compiled in). Session 22: no longer the
// working directory's assets/exercises first: a command started elsewhere silently used
// another copy of the exercises (score_rank_bench from a worktree scored main's).
std::string builtin_exercise_dir() {
  if (const char* e = std::getenv("DENTAR_ASSETS"); e != nullptr && *e != '\0') return std::string(e) + "/exercises";
  return std::string(DENTAR_ASSETS_DIR) + "/exercises";
}

Result<Exercise> load_builtin_exercise(const std::string& name) {
  const std::string path = builtin_exercise_dir() + "/" + name + ".json";
  if (!std::filesystem::exists(path)) {
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(builtin_exercise_dir(), ec))
      if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    if (names.empty())
      return Error{"no built-in exercise '" + name + "' (looked for " + path +
                   "; set DENTAR_ASSETS to the assets folder, or give an exercise .json file)"};
    return Error{"no built-in exercise '" + name + "' (built-in: " + list + "; or give an exercise .json file)"};
  }
  return load_exercise(path);
}

Result<volume::VoxelVolume> make_tooth(const std::string& tooth_json) {
  json j = json::parse(tooth_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("kind") || !j["kind"].is_string())
    return Error{"tooth description '" + tooth_json + "': needs {\"kind\": \"molar\"|\"incisor\"}"};
  const std::string kind = j["kind"].get<std::string>();
  double vox = -1;
  if (j.contains("voxel_mm")) {
    if (!j["voxel_mm"].is_number()) return Error{"tooth description: field 'voxel_mm' must be a number"};
    vox = j["voxel_mm"].get<double>();
  }
  if (kind == "molar") {
    volume::MolarParams p;
    if (vox > 0) p.voxel_mm = vox;
    if (j.contains("pulp_roof_mm")) {
      if (!j["pulp_roof_mm"].is_number()) return Error{"tooth description: field 'pulp_roof_mm' must be a number"};
      p.pulp_roof_mm = j["pulp_roof_mm"].get<double>();
    }
    return volume::make_molar(p);
  }
  if (kind == "incisor") {
    volume::IncisorParams p;
    if (vox > 0) p.voxel_mm = vox;
    return volume::make_incisor(p);
  }
  return Error{"tooth description: unknown kind '" + kind + "' (molar, incisor)"};
}

Result<volume::VoxelVolume> make_start_tooth(const std::string& tooth_json, std::uint64_t start_hash) {
  auto t = make_tooth(tooth_json);
  if (!t || t->content_hash() == start_hash) return t;
  json j = json::parse(tooth_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("kind", std::string()) != "molar" || j.contains("pulp_roof_mm"))
    return t;
  volume::MolarParams p;
  j["pulp_roof_mm"] = volume::kLegacyMolarPulpRoofFraction * p.crown_height_mm;
  auto legacy = make_tooth(j.dump());
  if (legacy && legacy->content_hash() == start_hash) return legacy;
  return t;
}

std::vector<float> distance_to_air_m(const volume::VoxelVolume& vol) {
  const Eigen::Vector3i d = vol.dims();
  const std::size_t n = static_cast<std::size_t>(vol.geometry().voxel_count());
  constexpr float kInf = 1e30f;
  std::vector<float> dist(n, 0.f);
  auto idx = [&](int i, int j, int k) {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(d.x()) * (static_cast<std::size_t>(j) + static_cast<std::size_t>(d.y()) * k);
  };
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i)
        // Sources: outside air (not solid and not pulp): the shell follows the outer surface.
        dist[idx(i, j, k)] = (vol.density(i, j, k) > kIsoDensity ||
                              (vol.density(i, j, k) > 0 && vol.material(i, j, k) == volume::Material::kPulp))
                                 ? kInf
                                 : 0.f;
  // 3-4-5 chamfer, forward then backward pass; outside the volume is air.
  auto pass = [&](int sgn) {
    const int k0 = sgn > 0 ? 0 : d.z() - 1, k1 = sgn > 0 ? d.z() : -1;
    const int j0 = sgn > 0 ? 0 : d.y() - 1, j1 = sgn > 0 ? d.y() : -1;
    const int i0 = sgn > 0 ? 0 : d.x() - 1, i1 = sgn > 0 ? d.x() : -1;
    for (int k = k0; k != k1; k += sgn)
      for (int j = j0; j != j1; j += sgn)
        for (int i = i0; i != i1; i += sgn) {
          float& v = dist[idx(i, j, k)];
          if (v == 0.f) continue;
          float best = v;
          for (int dk = -1; dk <= 0; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) {
                if (dk == 0 && (dj > 0 || (dj == 0 && di >= 0))) continue;
                const int ii = i + sgn * di, jj = j + sgn * dj, kk = k + sgn * dk;
                const int nz = (di != 0) + (dj != 0) + (dk != 0);
                const float w = nz == 1 ? 3.f : nz == 2 ? 4.f : 5.f;
                const bool inside = ii >= 0 && jj >= 0 && kk >= 0 && ii < d.x() && jj < d.y() && kk < d.z();
                const float nv = inside ? dist[idx(ii, jj, kk)] : 0.f;
                best = std::min(best, nv + w);
              }
          v = best;
        }
  };
  pass(+1);
  pass(-1);
  const double h = vol.spacing().minCoeff();
  for (auto& v : dist) v = static_cast<float>(v / 3.0 * h);
  return dist;
}

Result<RegionMasks> build_masks(const Exercise& ex, const volume::VoxelVolume& start) {
  RegionMasks m;
  m.dims = start.dims();
  const std::size_t n = static_cast<std::size_t>(start.geometry().voxel_count());
  m.bits.assign(n, 0u);
  bool need_dist = false;
  for (const auto& r : ex.regions)
    for (const auto& p : r.all) need_dist |= p.kind == PrimitiveKind::kShell;
  std::vector<float> dist;
  if (need_dist) dist = distance_to_air_m(start);
  for (std::size_t r = 0; r < ex.regions.size(); ++r) {
    const std::uint32_t bit = 1u << r;
    if (ex.regions[r].role == RegionRole::kTarget) m.target_bits |= bit;
    if (ex.regions[r].role == RegionRole::kForbidden) m.forbidden_bits |= bit;
    if (ex.regions[r].role == RegionRole::kEntry) m.entry_bits |= bit;
  }
  std::vector<std::size_t> count(ex.regions.size(), 0);
  const Eigen::Vector3i d = m.dims;
  for (int k = 0; k < d.z(); ++k)
    for (int j = 0; j < d.y(); ++j)
      for (int i = 0; i < d.x(); ++i) {
        const Eigen::Vector3d p = start.voxel_center(i, j, k);
        const std::size_t id = m.index(i, j, k);
        const std::uint8_t dens = start.density(i, j, k);
        // Tooth: every voxel with material in it, the partial-volume skin
        // (0 < density <= iso) included. Before issue 25 (session 11) the
        // skin over a target was in no region: shaving it off counted as
        // over-preparation outside every target (4-7 mm3 of an incisor
        // preparation at every skill level, 0.15 mm voxels).
        const bool solid = dens > 0;
        std::uint32_t b = 0;
        for (std::size_t r = 0; r < ex.regions.size(); ++r) {
          bool in = true;
          for (const auto& pr : ex.regions[r].all) {
            bool v;
            switch (pr.kind) {
              case PrimitiveKind::kMaterial: v = dens > 0 && start.material(i, j, k) == pr.material; break;
              case PrimitiveKind::kShell: v = solid && dist[id] <= pr.depth_m; break;
              case PrimitiveKind::kSolid: v = solid; break;
              default: v = pr.contains(p); in = in && v; continue;
            }
            if (pr.negate) v = !v;
            in = in && v;
            if (!in) break;
          }
          if (in) {
            b |= 1u << r;
            ++count[r];
          }
        }
        if ((b & m.target_bits) && (b & m.forbidden_bits)) {
          std::string t, f;
          for (std::size_t r = 0; r < ex.regions.size(); ++r) {
            if ((b >> r & 1u) && ex.regions[r].role == RegionRole::kTarget && t.empty()) t = ex.regions[r].name;
            if ((b >> r & 1u) && ex.regions[r].role == RegionRole::kForbidden && f.empty()) f = ex.regions[r].name;
          }
          std::ostringstream os;
          os.precision(3);
          os << ex.source << ": target region '" << t << "' overlaps forbidden region '" << f
             << "' (first shared voxel at (" << p.x() * 1e3 << ", " << p.y() * 1e3 << ", "
             << p.z() * 1e3 << ") mm); shrink one of them so no voxel is in both";
          return Error{os.str()};
        }
        m.bits[id] = b;
      }
  for (std::size_t r = 0; r < ex.regions.size(); ++r)
    if (count[r] == 0 && ex.regions[r].role == RegionRole::kTarget)
      return Error{ex.source + ": target region '" + ex.regions[r].name +
                   "' covers no voxel of the tooth; check its shapes against the tooth frame"};
  return m;
}

Result<Exercise> load_named_exercise(const std::string& name_or_path) {
  const bool file = name_or_path.find(".json") != std::string::npos || name_or_path.find('/') != std::string::npos;
  return file ? load_exercise(name_or_path) : load_builtin_exercise(name_or_path);
}

}  // namespace dentar::training
