#include "io/progress.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <iostream>
#include <string>

namespace raycloth {

Progress::Progress(bool quiet, int total) : quiet_(quiet), tty_(isatty(STDERR_FILENO)), total_(total) {}

void Progress::update(int done, double elapsed) {
  if (quiet_ || total_ <= 0) return;
  const double frac = double(done) / total_;
  const double eta = done > 0 ? elapsed * (total_ - done) / done : 0.0;
  if (tty_) {
    const int width = 30, filled = int(frac * width);
    std::cerr << fmt::format("\r[{}{}] {:3.0f}% frame {}/{} ETA {:.0f}s ", std::string(filled, '#'),
                             std::string(width - filled, '.'), frac * 100, done, total_, eta)
              << std::flush;
    if (done == total_) std::cerr << "\n";
  } else if (done * 10 / total_ != last_decile_ || done == total_) {
    last_decile_ = done * 10 / total_;
    spdlog::info("frame {}/{} ({:.0f}%), ETA {:.0f} s", done, total_, frac * 100, eta);
  }
}

}  // namespace raycloth
