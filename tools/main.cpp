// dentar: the command line. Each subcommand is a thin layer over the libraries.
#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"DentAR: augmented-reality dental drilling trainer"};
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
