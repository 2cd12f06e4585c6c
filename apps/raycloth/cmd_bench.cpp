#include "commands.h"

namespace raycloth::cli {

Action add_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Measure steps per second and time per stage");
  return [bench] { return bench->parsed() ? 0 : 0; };
}

}  // namespace raycloth::cli
