#include "render/video.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

extern char** environ;

namespace raycloth {

namespace fs = std::filesystem;

std::string ffmpeg_program() {
  const char* env = std::getenv("RAYCLOTH_FFMPEG");
  return env && *env ? env : "ffmpeg";
}

namespace {

// The last `lines` lines of s, without a trailing newline.
std::string tail(std::string s, int lines) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  size_t pos = s.size();
  for (int i = 0; i < lines && pos != std::string::npos && pos > 0; ++i) pos = s.rfind('\n', pos - 1);
  return pos == std::string::npos ? s : s.substr(pos + 1);
}

}  // namespace

VideoResult make_video(const fs::path& out_dir, int frames, double fps) {
  const std::string program = ffmpeg_program();
  const fs::path video = out_dir / "video.mp4";
  fs::path tmp = video;
  tmp += ".tmp";
  const std::string rate = fmt::format("{:g}", fps);
  const std::vector<std::string> args{program, "-nostdin", "-y", "-loglevel", "error",
                                      "-framerate", rate, "-start_number", "0",
                                      "-i", (out_dir / "images" / "frame_%04d.png").string(),
                                      "-frames:v", std::to_string(frames),
                                      "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                      "-c:v", "libx264", "-pix_fmt", "yuv420p", "-r", rate,
                                      "-f", "mp4", tmp.string()};
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  int err_pipe[2];
  if (pipe(err_pipe) != 0) throw std::runtime_error(std::string("cannot start ffmpeg: pipe: ") + std::strerror(errno));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, err_pipe[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, err_pipe[0]);
  posix_spawn_file_actions_addclose(&actions, err_pipe[1]);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(err_pipe[1]);
  if (spawned != 0) {
    close(err_pipe[0]);
    VideoResult r;
    r.warning = fmt::format(
        "cannot run ffmpeg '{}' ({}): no video; the images are in {}. Install ffmpeg (apt-get install ffmpeg) "
        "or set RAYCLOTH_FFMPEG to its path, then run: raycloth render {} --video",
        program, std::strerror(spawned), (out_dir / "images").string(), out_dir.string());
    return r;
  }
  std::string errors;
  char buf[4096];
  for (ssize_t n; (n = read(err_pipe[0], buf, sizeof buf)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    errors.append(buf, size_t(n));
  }
  close(err_pipe[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::error_code ec;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    fs::remove(tmp, ec);
    const std::string how = WIFEXITED(status) ? fmt::format("exit code {}", WEXITSTATUS(status))
                                              : fmt::format("signal {}", WTERMSIG(status));
    throw std::runtime_error(fmt::format("{}: ffmpeg failed ({}), the images are kept: {}", video.string(), how,
                                         tail(errors, 5)));
  }
  fs::rename(tmp, video, ec);
  if (ec) throw std::runtime_error(video.string() + ": cannot rename from " + tmp.string() + ": " + ec.message());
  return VideoResult{true, ""};
}

}  // namespace raycloth
