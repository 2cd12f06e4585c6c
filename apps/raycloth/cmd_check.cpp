// `raycloth check DIR`: the exact penetration check of every frame of an output folder.
// Exit codes: 0 every frame clean, 1 some frame has a crossing or a vertex inside (a failure), 2 bad
// input, 3 the only problems are pinches (cloth vertices inside the body where its own surfaces are
// closer than twice the cloth thickness, read from DIR/run.json).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include "check/folder_check.h"
#include "commands.h"
#include "common.h"

namespace raycloth::cli {

Action add_check_command(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto quiet = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand(
      "check",
      "Exact penetration check of every frame in an output folder (exit 0 clean, 1 penetration, 2 bad input, 3 only "
      "pinches)");
  cmd->add_option("dir", *dir, "Output folder of `raycloth run` (frames/cloth_NNNN.obj, obstacles.obj)")->required();
  cmd->add_flag("-q,--quiet", *quiet, "Only the summary line");
  return [cmd, dir, quiet] {
    if (!cmd->parsed()) return 0;
    return guarded([&] {
      const FolderCheck c = check_output_folder(*dir, [&](const FolderFrameCheck& f) {
        if (!*quiet && !f.report.clean()) std::cout << fmt::format("frame {:04d}: {}\n", f.frame, describe(f.report));
      });
      size_t crossings = 0, inside = 0, pinched = 0, pairs = 0;
      double gap = HUGE_VAL;
      for (const auto& f : c.frames) {
        crossings += f.report.crossings;
        inside += f.report.vertices_inside;
        pinched += f.report.vertices_pinched;
        gap = std::min(gap, f.report.min_pinch_gap);
        pairs += f.report.pairs_tested;
      }
      const auto& last = c.frames.back().report;
      std::cout << fmt::format(
          "{}: {} frames, {} bad: {} edge-triangle crossings and {} vertices inside in all "
          "({} edge-triangle pairs tested; {} edges, {} triangles, {} closed and {} open obstacles)\n",
          *dir, c.frames.size(), c.bad_frames(), crossings, inside, pairs, last.edges, last.triangles,
          last.closed_obstacles, last.open_obstacles);
      if (pinched > 0)
        std::cout << fmt::format(
            "{}: {} frames pinched only: {} cloth vertices pinched in all, inside the body where its own surfaces are "
            "closer than twice the cloth thickness ({:.3g} mm); smallest body gap {:.3g} mm\n",
            *dir, c.pinched_frames(), pinched, 2e3 * c.thickness, 1e3 * gap);
      if (c.bad_frames() > 0) return 1;
      if (c.pinched_frames() == 0) return 0;
      std::cerr << fmt::format("raycloth: pinched: {}: the only problems are pinches, in {} of {} frames (exit status 3)\n",
                               *dir, c.pinched_frames(), c.frames.size());
      return 3;
    });
  };
}

}  // namespace raycloth::cli
