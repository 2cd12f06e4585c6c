// `raycloth view DIR`: writes DIR/view.html, a page that plays the run in a browser (io/viewer.h).
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "commands.h"
#include "common.h"
#include "io/viewer.h"

namespace raycloth::cli {

Action add_view_command(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto no_check = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("view", "Write DIR/view.html: the run in a browser, from disk (three.js inlined)");
  cmd->add_option("dir", *dir, "Output folder of `raycloth run` (frames/cloth_NNNN.obj)")->required();
  cmd->add_flag("--no-check", *no_check, "Leave out the per-frame exact check (faster for long runs)");
  return [cmd, dir, no_check] {
    if (!cmd->parsed()) return 0;
    return guarded([&] {
      const ViewSummary s = write_view(*dir, !*no_check);
      std::cout << fmt::format("wrote {} ({} frames, {} cloth vertices, {:.1f} MB{}); open it in a browser\n",
                               s.page.string(), s.frames, s.cloth_vertices, double(s.bytes) / 1e6,
                               s.checked ? fmt::format(", {} frames failed the exact check", s.bad_frames) : "");
      return 0;
    });
  };
}

}  // namespace raycloth::cli
