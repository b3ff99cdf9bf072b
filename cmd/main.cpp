// rayproof: is your ray intersection code right, how wrong is it, where, and at what cost.
#include <cerrno>
#include <cstring>
#include <iostream>

#include "rayproof/core/json_fields.h"

#include "commands.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/verify/certified.h"

int main(int argc, char** argv) {
  rayproof::register_certified_variants();
  // Whatever rayproof's children start is ended with them, and none outlives rayproof.
  rayproof::peers::adopt_orphans();
  rayproof::peers::use_exec_launcher();
  CLI::App app{"rayproof: exact audits, fuzzing and benchmarks of ray intersection code"};
  app.require_subcommand(1);
  int exit_code = 0;
  rayproof::cli::add_variants_command(app, exit_code);
  rayproof::cli::add_intersect_command(app, exit_code);
  rayproof::cli::add_render_command(app, exit_code);
  rayproof::cli::add_check_command(app, exit_code);
  rayproof::cli::add_fuzz_command(app, exit_code);
  rayproof::cli::add_spawn_command(app, exit_code);
  rayproof::cli::add_trade_command(app, exit_code);
  rayproof::cli::add_stability_command(app, exit_code);
  rayproof::cli::add_merge_command(app, exit_code);
  rayproof::cli::add_audit_command(app, exit_code);
  rayproof::cli::add_offsets_command(app, exit_code);
  // Exit codes: 0 done (fuzz: whatever it found); 1 check found bad lines or refuted
  // expectations (intersect: bad lines); 2 a usage or I/O error.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    std::cerr << "rayproof: " << rayproof::printable(e.what()) << "\n";
    return 2;
  }
  errno = 0;
  std::cout.flush();
  if (!std::cout) {
    std::cerr << "rayproof: standard output: write failed" << (errno ? std::string(": ") + std::strerror(errno) : "")
              << "\n";
    return 2;
  }
  return exit_code;
}
