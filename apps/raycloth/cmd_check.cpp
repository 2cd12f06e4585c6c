// `raycloth check DIR`: the exact penetration check of every frame of an output folder.
// Exit codes: 0 every frame clean, 1 some frame has a crossing or a vertex inside, 2 bad input.
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "check/state_check.h"
#include "commands.h"

namespace raycloth::cli {

Action add_check_command(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto quiet = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand(
      "check", "Exact penetration check of every frame in an output folder (exit 0 clean, 1 penetration, 2 bad input)");
  cmd->add_option("dir", *dir, "Output folder of `raycloth run` (frames/cloth_NNNN.obj, obstacles.obj)")->required();
  cmd->add_flag("-q,--quiet", *quiet, "Only the summary line");
  return [cmd, dir, quiet] {
    if (!cmd->parsed()) return 0;
    return guarded([&] {
      const FolderCheck c = check_output_folder(*dir, [&](const FolderFrameCheck& f) {
        if (!*quiet && !f.report.clean()) std::cout << fmt::format("frame {:04d}: {}\n", f.frame, describe(f.report));
      });
      size_t crossings = 0, inside = 0, pairs = 0;
      for (const auto& f : c.frames) {
        crossings += f.report.crossings;
        inside += f.report.vertices_inside;
        pairs += f.report.pairs_tested;
      }
      const auto& last = c.frames.back().report;
      std::cout << fmt::format(
          "{}: {} frames, {} bad: {} edge-triangle crossings and {} vertices inside in all "
          "({} edge-triangle pairs tested; {} edges, {} triangles, {} closed and {} open obstacles)\n",
          *dir, c.frames.size(), c.bad_frames(), crossings, inside, pairs, last.edges, last.triangles,
          last.closed_obstacles, last.open_obstacles);
      return c.bad_frames() == 0 ? 0 : 1;
    });
  };
}

}  // namespace raycloth::cli
