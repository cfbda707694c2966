// cansimctl: command-line client of cansimd's D-Bus control API
// (docs/control-api.md). Everything but the entry point is in cansim_ctl.
#include <iostream>

#include "ctl/commands.hpp"

int main(int argc, char** argv) {
  return cansim::ctl::cansimctl_main(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
