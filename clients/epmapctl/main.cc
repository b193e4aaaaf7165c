// epmapctl: query and drive epmapd over gRPC.
//   epmapctl [--server HOST:PORT] [--timeout S] <command> ...   (epmapctl --help lists them)

#include <CLI/CLI.hpp>

#include "clients/epmapctl/client.h"

int main(int argc, char** argv) {
  CLI::App app("epmapctl: query epmapd's maps and run its calibration jobs over gRPC");
  epmap::ctl::ClientOptions options;
  app.add_option("--server", options.server, "epmapd's gRPC address")->capture_default_str();
  app.add_option("--timeout", options.timeout_s, "deadline of each call, seconds")
      ->capture_default_str();
  app.require_subcommand(1);
  for (const auto& setup : epmap::ctl::CommandSetups()) setup(app, options);
  CLI11_PARSE(app, argc, argv);
  return options.exit_code;
}
