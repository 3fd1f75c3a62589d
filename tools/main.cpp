// dentar: the command line. Each subcommand is a thin layer over the libraries.
#include <iostream>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "DentAR: augmented-reality dental drilling trainer.\n"
      "Run `dentar <subcommand> --help` for the options of each job."};
  app.footer("Example:\n  dentar demo --out out/demo");
  app.require_subcommand(1, 1);
  app.set_version_flag("--version", "dentar 0.1.0");
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;  // --help is not an error; bad arguments are
  }
  return exit_code;
}
