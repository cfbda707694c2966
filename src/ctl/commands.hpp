// Carries out a cansimctl command line: connects, calls, prints.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "ctl/connection.hpp"
#include "ctl/output.hpp"

namespace cansim::ctl {

// Calls the request's method and prints the reply; watch runs until SIGINT or
// SIGTERM. Returns the exit status; a refused call throws Failure.
int run_request(Connection& connection, const Request& request, Printer& printer);

// The whole program: args without argv[0]. Output on out, messages on err.
// Exit status 0 done, 1 refused or no connection, 2 bad command line.
int cansimctl_main(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace cansim::ctl
