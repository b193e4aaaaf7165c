#pragma once
// Subcommands of epmap-bench register themselves here with a static EPMAP_BENCH_COMMAND, so
// that a new benchmark is one new file and no shared edit.

#include <functional>
#include <string>
#include <vector>

namespace epmap::bench {

struct Command {
  std::string name;
  std::string summary;
  // Receives the arguments after the subcommand name (argv[0] = "epmap-bench <name>").
  std::function<int(int argc, char** argv)> run;
};

std::vector<Command>& Commands();

struct Registrar {
  explicit Registrar(Command command) { Commands().push_back(std::move(command)); }
};

}  // namespace epmap::bench

#define EPMAP_BENCH_COMMAND(ident, name, summary, fn) \
  static ::epmap::bench::Registrar ident##_registrar({name, summary, fn})
