// Helpers shared by the subcommands (kept out of main.cpp so no subcommand
// depends on the file that registers it).
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "commands.h"

namespace dentar::tools {
CLI::Validator at_least(double min) {
  std::ostringstream m;
  m << min;
  const std::string lo = m.str();
  return CLI::Validator(
      [min, lo](std::string& v) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end != '\0' || !std::isfinite(x)) return "must be a number (" + lo + " or more), got " + v;
        if (x < min) return "must be " + lo + " or more, got " + v;
        return {};
      },
      "NUMBER >= " + lo);
}

void print_error(const std::string& cmd, const std::string& message) {
  std::cerr << "dentar " << cmd << ": " << message << "\n";
}

void add_tracker_image_options(CLI::App* sub, std::string& camera_response, bool& mirror_rim) {
  sub->add_option("--camera-response", camera_response,
                  "How the video's grey levels relate to light, for the linear-light refit of tag edges "
                  "(tags are always searched on the image as delivered): auto (the default: the "
                  "station's camera.response, measured by dentar calibrate camera; unknown = no refit, "
                  "with a note), srgb (video cameras, dentar synth) or linear (raw machine-vision "
                  "cameras). Replaying a dentar live recording: the recording's own, unless given");
  sub->add_flag("--mirror-rim", mirror_rim,
                "Refine the mirror's pose from its rim ellipse in the image (issue 16; "
                "docs/BENCHMARKS.md)");
}

void add_stereo_mirror_rim_option(CLI::App* sub, std::string& value) {
  sub->add_option("--stereo-mirror-rim", value,
                  "With two eyes: refine the mirror's joint fit from its rim ellipse in each eye (default on; "
                  "off = the mirror's tags alone, session 15's stereo fit). Issue 28, docs/BENCHMARKS.md")
      ->check(CLI::IsMember({"on", "off"}));
}
}  // namespace dentar::tools
