// dentar: the command line. Each subcommand is a thin layer over the libraries.
#include <cstring>
#include <iostream>
#include <memory>

#include "commands.h"
#include "log_filter.h"

// tools/cmd_replay.cpp (issue 27): declared here, beside its one caller.
namespace dentar::tools {
void add_replay(CLI::App& app, int& exit_code);
}

int main(int argc, char** argv) {
  // Library log lines (FFmpeg, libjpeg, libapriltag, OpenCV) are held back unless --verbose
  // (log_filter.h); decided before anything runs, so the filter is up before any thread.
  bool verbose = false;
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--verbose") == 0) verbose = true;
  std::unique_ptr<dentar::tools::LibraryLogFilter> filter;
  if (!verbose) filter = std::make_unique<dentar::tools::LibraryLogFilter>();

  CLI::App app{
      "DentAR: augmented-reality dental drilling trainer.\n"
      "Run `dentar <subcommand> --help` for the options of each job."};
  app.footer(
      "Exit codes (every subcommand): 0 done, 1 the job failed, 2 bad input or arguments.\n"
      "Example:\n  dentar demo --out out/demo");
  app.require_subcommand(1, 1);
  app.set_version_flag("--version", "dentar 0.1.0");
  // Accepted before or after the subcommand (subcommands fall through to it).
  app.add_flag("--verbose", verbose,
               "also show the libraries' own log lines (FFmpeg, libjpeg, libapriltag, OpenCV), held back otherwise");
  app.fallthrough();
  int exit_code = 0;
  dentar::tools::add_demo(app, exit_code);
  dentar::tools::add_tooth(app, exit_code);
  dentar::tools::add_ct(app, exit_code);
  dentar::tools::add_synth(app, exit_code);
  dentar::tools::add_track(app, exit_code);
  dentar::tools::add_calibrate(app, exit_code);
  dentar::tools::add_offline(app, exit_code);
  dentar::tools::add_score(app, exit_code);
  dentar::tools::add_assess(app, exit_code);
  dentar::tools::add_devices(app, exit_code);
  dentar::tools::add_tags(app, exit_code);
  dentar::tools::add_live(app, exit_code);
  dentar::tools::add_db(app, exit_code);
  dentar::tools::add_serve(app, exit_code);
  dentar::tools::add_lesson(app, exit_code);
  dentar::tools::add_replay(app, exit_code);

  dentar::tools::add_sound(app, exit_code);
  int rc = 0;
  try {
    app.parse(argc, argv);
    rc = exit_code;
  } catch (const CLI::ParseError& e) {
    rc = app.exit(e) == 0 ? 0 : 2;  // --help is not an error; bad arguments are
  }
  if (filter) {
    std::cout.flush();
    const std::size_t held = filter->finish();
    // Only where it matters: a failed run whose reason may sit in a library's line.
    if (held > 0 && rc != 0)
      std::cerr << "(" << held << " log line" << (held > 1 ? "s" : "") << " of FFmpeg/libjpeg/libapriltag/OpenCV "
                << "held back; --verbose shows them)\n";
  }
  return rc;
}
