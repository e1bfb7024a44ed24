// Progress of a long run on stderr: a redrawn bar with rate and ETA when stderr is a terminal, a
// plain line every `line_interval` seconds otherwise (logs, SLURM output files). Tick() is
// thread-safe and cheap (atomic increments); a background thread does the printing.
//
// The counts and the percentage are items (trials). Items can carry a weight (a trial's number of
// samples): the ETA is then taken over the weights left, and says so, so a sweep whose trials differ
// 50-fold in cost (δt = 1e-4 vs 5e-3) still gets a fair ETA. The last line ends in "done", or in
// "stopped" when fewer items than the total were ticked (an interrupted run).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace hysid {

class Progress {
 public:
  enum class Mode { kAuto, kBar, kLines, kNone };
  // `total_weight` ≤ 0: every item weighs 1.
  Progress(std::string label, long total, long already_done, Mode mode, double total_weight = 0.0,
           double done_weight = 0.0, double line_interval = 10.0);
  ~Progress();  // prints the final state
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void Tick(long weight = 1) {
    done_.fetch_add(1, std::memory_order_relaxed);
    weight_done_.fetch_add(weight, std::memory_order_relaxed);
  }

 private:
  void Loop();
  void Print(bool final);

  std::string label_;
  long total_, start_done_;
  std::atomic<long> done_;
  double total_weight_;
  bool weighted_;
  double start_weight_;
  std::atomic<long> weight_done_;
  Mode mode_;
  double line_interval_;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

// The stage of one long computation (an identification) on one line of stderr, redrawn every 250 ms
// ("identify: refinement, fit 3, iteration 12, cost 1234.5, 4s"), shown only once the work has run
// `delay` seconds: kBar (kAuto when stderr is a terminal) redraws the line, kLines prints it every
// `line_interval` seconds, kNone (kAuto when stderr is not a terminal) prints nothing. Clear() erases
// the line before the caller prints (it is drawn again at the next Stage). Thread-safe.
class StageProgress {
 public:
  StageProgress(std::string label, Progress::Mode mode, double delay = 1.0, double line_interval = 10.0);
  ~StageProgress();  // erases the line
  StageProgress(const StageProgress&) = delete;
  StageProgress& operator=(const StageProgress&) = delete;

  void Stage(std::string stage);                    // a new stage: its fit, iteration and cost forgotten
  void Iteration(int fit, int iteration, double cost);
  void Clear();                                     // no stage: the line erased

 private:
  void Loop();
  void Draw();   // under mutex_
  void Erase();  // under mutex_

  std::string label_;
  Progress::Mode mode_;
  double delay_, line_interval_;
  std::chrono::steady_clock::time_point start_, last_line_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false, drawn_ = false;
  std::string stage_;
  int fit_ = 0, iteration_ = -1;
  double cost_ = 0.0;
  std::thread thread_;
};

}  // namespace hysid
