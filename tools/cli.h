#pragma once
// What the command-line tools share: their exit codes and how a command line
// that CLI11 refuses is reported.
#include <CLI/CLI.hpp>

#include <iostream>
#include <optional>

namespace sis::cli {

// Besides 0 (done) and 1 (any other error):
constexpr int kExitUsage = 2, kExitInput = 3, kExitOutput = 4;

// Parses the command line. Returns the code to exit with when the run stops
// here: --help printed (0), or a usage error, reported on stderr as
// "NAME: what" with a pointer to --help (kExitUsage). Nothing when it goes on.
// Tools built with version.h give --version: the version and git revision.
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --version: printed, done
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << app.get_name() << ": " << e.what() << "\n(run " << app.get_name()
              << " --help for the options)\n";
    return kExitUsage;
  }
  return std::nullopt;
}

}  // namespace sis::cli
