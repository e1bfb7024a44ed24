// Progress of a long run on stderr: a redrawn bar with rate and ETA when stderr is a terminal, a
// plain line every `line_interval` seconds otherwise (logs, SLURM output files). Tick() is
// thread-safe and cheap (one atomic increment); a background thread does the printing.
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
  Progress(std::string label, long total, long already_done, Mode mode, double line_interval = 10.0);
  ~Progress();  // prints the final state
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void Tick() { done_.fetch_add(1, std::memory_order_relaxed); }

 private:
  void Loop();
  void Print(bool final);

  std::string label_;
  long total_, start_done_;
  std::atomic<long> done_;
  Mode mode_;
  double line_interval_;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace hysid
