// A run's progress on stderr: a bar with an ETA on a terminal, a log line per tenth of the run
// otherwise, nothing when quiet.
#pragma once

namespace raycloth {

class Progress {
 public:
  Progress(bool quiet, int total);
  // After `done` of the `total` frames, `elapsed` wall-clock seconds into the run.
  void update(int done, double elapsed);

 private:
  bool quiet_, tty_;
  int total_;
  int last_decile_ = 0;
};

}  // namespace raycloth
