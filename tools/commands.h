// Subcommand registration for the `dentar` command line. Each add_* function
// adds one subcommand with its options and callback; the callback sets
// `exit_code` (0 ok, 1 failure of the job, 2 bad input).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace dentar::tools {

void add_demo(CLI::App& app, int& exit_code);
void add_tooth(CLI::App& app, int& exit_code);
void add_ct(CLI::App& app, int& exit_code);
void add_synth(CLI::App& app, int& exit_code);
void add_track(CLI::App& app, int& exit_code);
void add_calibrate(CLI::App& app, int& exit_code);
void add_offline(CLI::App& app, int& exit_code);
void add_score(CLI::App& app, int& exit_code);
void add_assess(CLI::App& app, int& exit_code);
void add_devices(CLI::App& app, int& exit_code);
void add_tags(CLI::App& app, int& exit_code);
void add_live(CLI::App& app, int& exit_code);
void add_db(CLI::App& app, int& exit_code);
void add_serve(CLI::App& app, int& exit_code);
void add_lesson(CLI::App& app, int& exit_code);

void add_sound(CLI::App& app, int& exit_code);

// The tracker's image options shared by `offline` and `track`:
// --camera-response (auto|srgb|linear, parsed by the caller; left empty when not
// given, so a replay can take the recording's) and --mirror-rim.
void add_tracker_image_options(CLI::App* sub, std::string& camera_response, bool& mirror_rim);
// --stereo-mirror-rim on|off (TrackerOptions::stereo_mirror_rim); `value` stays empty unless given.
void add_stereo_mirror_rim_option(CLI::App* sub, std::string& value);

// A number of at least `min`, with a message for people ("must be 0 or more, got -1"), not
// CLI11's range with std::numeric_limits' 300-digit bound.
CLI::Validator at_least(double min);

// Prints "dentar <cmd>: <message>" to stderr.
void print_error(const std::string& cmd, const std::string& message);

}  // namespace dentar::tools
