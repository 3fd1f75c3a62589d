// `dentar live --cpu-layout`: see cpu_layout.h.
#include "dentar/live/cpu_layout.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cctype>

namespace dentar::live {
namespace {

bool all_digits(const std::string& s) {
  return !s.empty() && s.size() <= 4 && std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; });
}

// One CPUS value into `cpus` ("" or the error, without the role's name).
std::string parse_cpus(const std::string& v, int ncpu, std::vector<int>& cpus) {
  cpus.clear();
  if (v == "all") {
    if (ncpu <= 0) {
      cpus = {-1};
      return {};
    }
    for (int c = 0; c < ncpu; ++c) cpus.push_back(c);
    return {};
  }
  if (v.empty()) return "no CPU given";
  std::size_t at = 0;
  while (at <= v.size()) {
    const std::size_t plus = v.find('+', at);
    const std::string part = v.substr(at, plus == std::string::npos ? std::string::npos : plus - at);
    const std::size_t dash = part.find('-');
    const std::string a = part.substr(0, dash), b = dash == std::string::npos ? a : part.substr(dash + 1);
    if (!all_digits(a) || !all_digits(b))
      return "\"" + part + "\" is not a CPU, a range such as 0-1, or all";
    const int lo = std::stoi(a), hi = std::stoi(b);
    if (hi < lo) return "the range " + part + " runs backwards";
    if (ncpu > 0 && hi >= ncpu)
      return "CPU " + std::to_string(hi) + " does not exist: this machine has " + std::to_string(ncpu) + " (0-" +
             std::to_string(ncpu - 1) + ")";
    for (int c = lo; c <= hi; ++c) cpus.push_back(c);
    if (plus == std::string::npos) break;
    at = plus + 1;
  }
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return {};
}

}  // namespace

const char* CpuLayout::name(Role r) {
  switch (r) {
    case kEngine: return "engine";
    case kFrame: return "frame";
    case kEye: return "eye";
    case kCaptureLeft: return "capture-l";
    case kCaptureRight: return "capture-r";
    case kDisplay: return "display";
    case kRaster: return "raster";
    case kMesher: return "mesher";
    default: return "?";
  }
}

bool CpuLayout::empty() const {
  return std::all_of(cpus.begin(), cpus.end(), [](const std::vector<int>& c) { return c.empty(); });
}

std::string CpuLayout::text() const {
  std::string s;
  for (int r = 0; r < kRoles; ++r) {
    const std::vector<int>& c = cpus[static_cast<std::size_t>(r)];
    if (c.empty()) continue;
    if (!s.empty()) s += ",";
    s += std::string(name(static_cast<Role>(r))) + "=";
    for (std::size_t i = 0; i < c.size(); ++i) s += (i > 0 ? "+" : "") + (c[i] < 0 ? std::string("all") : std::to_string(c[i]));
  }
  return s;
}

std::string parse_cpu_layout(const std::string& text, int ncpu, CpuLayout& out) {
  out = CpuLayout{};
  if (text.empty()) return {};
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = text.find(',', at);
    const std::string item = text.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      return "cpu_layout: \"" + item + "\" must be ROLE=CPUS (roles: engine, frame, eye, capture, capture-l, capture-r, "
             "display, raster, mesher)";
    const std::string role = item.substr(0, eq), value = item.substr(eq + 1);
    std::vector<int> cpus;
    if (std::string e = parse_cpus(value, ncpu, cpus); !e.empty())
      return "cpu_layout: " + role + "=" + value + ": " + e;
    using Role = CpuLayout::Role;
    std::vector<Role> roles;
    if (role == "capture") roles = {CpuLayout::kCaptureLeft, CpuLayout::kCaptureRight};
    for (int r = 0; r < CpuLayout::kRoles && roles.empty(); ++r)
      if (role == CpuLayout::name(static_cast<Role>(r))) roles = {static_cast<Role>(r)};
    if (roles.empty())
      return "cpu_layout: unknown role \"" + role + "\" (roles: engine, frame, eye, capture, capture-l, capture-r, "
             "display, raster, mesher)";
    for (const Role r : roles) {
      if (out.set(r)) return std::string("cpu_layout: ") + CpuLayout::name(r) + " given twice";
      out.cpus[static_cast<std::size_t>(r)] = cpus;
    }
    if (role == "engine" && (cpus.size() != 1 || cpus[0] < 0))
      return "cpu_layout: engine=" + value + ": the engine runs on one CPU";
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  return {};
}

bool pin_this_thread(const std::vector<int>& cpus) {
  if (cpus.empty()) return true;
  cpu_set_t set;
  CPU_ZERO(&set);
  for (const int c : cpus)
    if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
}

}  // namespace dentar::live
