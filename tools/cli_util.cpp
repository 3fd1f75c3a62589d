// Helpers shared by the subcommands (kept out of main.cpp so no subcommand
// depends on the file that registers it).
#include <iostream>

#include "commands.h"

namespace dentar::tools {
void print_error(const std::string& cmd, const std::string& message) {
  std::cerr << "dentar " << cmd << ": " << message << "\n";
}
}  // namespace dentar::tools
