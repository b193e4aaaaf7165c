// epmap-bench: benchmarks that print JSON with the baseline measured in the same run.
//   epmap-bench <command> [options]     (epmap-bench --help lists the commands)

#include <algorithm>
#include <cstring>
#include <iostream>
#include <string>

#include "bench/epmap_bench/command_registry.h"

namespace epmap::bench {
std::vector<Command>& Commands() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace epmap::bench

int main(int argc, char** argv) {
  auto& commands = epmap::bench::Commands();
  std::sort(commands.begin(), commands.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  const auto usage = [&](std::ostream& out) {
    out << "usage: epmap-bench <command> [options]\n\ncommands:\n";
    for (const auto& c : commands) out << "  " << c.name << "  " << c.summary << "\n";
    out << "\n'epmap-bench <command> --help' for a command's options.\n";
  };
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    usage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
  }
  for (const auto& c : commands) {
    if (c.name == argv[1]) {
      std::string self = std::string("epmap-bench ") + argv[1];
      argv[1] = self.data();
      return c.run(argc - 1, argv + 1);
    }
  }
  std::cerr << "epmap-bench: unknown command '" << argv[1] << "'\n";
  usage(std::cerr);
  return 2;
}
