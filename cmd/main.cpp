// rayproof: is your ray intersection code right, how wrong is it, where, and at what cost.
#include <iostream>

#include "commands.h"
#include "rayproof/verify/certified.h"

int main(int argc, char** argv) {
  rayproof::register_certified_variants();
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "rayproof: " << e.what() << "\n";
    return 1;
  }
  return exit_code;
}
