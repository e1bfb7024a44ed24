#include "experiments/sweep/progress.hpp"

#include <unistd.h>

#include <cstdio>
#include <string>

#include <fmt/format.h>

namespace hysid {
namespace {

std::string Duration(double s) {
  if (!(s >= 0) || s > 1e7) return "?";
  const long t = static_cast<long>(s + 0.5);
  if (t >= 3600) return fmt::format("{}h{:02}m", t / 3600, t / 60 % 60);
  if (t >= 60) return fmt::format("{}m{:02}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

}  // namespace

Progress::Progress(std::string label, long total, long already_done, Mode mode, double total_weight,
                   double done_weight, double line_interval)
    : label_(std::move(label)),
      total_(total),
      start_done_(already_done),
      done_(already_done),
      total_weight_(total_weight > 0 ? total_weight : static_cast<double>(total)),
      weighted_(total_weight > 0),
      start_weight_(total_weight > 0 ? done_weight : static_cast<double>(already_done)),
      weight_done_(static_cast<long>(total_weight > 0 ? done_weight : static_cast<double>(already_done))),
      mode_(mode),
      line_interval_(line_interval),
      start_(std::chrono::steady_clock::now()) {
  if (mode_ == Mode::kAuto) mode_ = ::isatty(STDERR_FILENO) ? Mode::kBar : Mode::kLines;
  if (mode_ != Mode::kNone) thread_ = std::thread([this] { Loop(); });
}

Progress::~Progress() {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
  Print(true);
}

void Progress::Loop() {
  const auto period = mode_ == Mode::kBar
                          ? std::chrono::milliseconds(250)
                          : std::chrono::milliseconds(static_cast<long>(line_interval_ * 1000));
  std::unique_lock lock(mutex_);
  while (!cv_.wait_for(lock, period, [this] { return stop_; })) Print(false);
}

void Progress::Print(bool final) {
  const long done = done_.load(std::memory_order_relaxed);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? static_cast<double>(done - start_done_) / elapsed : 0.0;
  const double w = static_cast<double>(weight_done_.load(std::memory_order_relaxed));
  const double wrate = elapsed > 0 ? (w - start_weight_) / elapsed : 0.0;
  const double frac = total_ > 0 ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
  std::string eta;
  if (final) {
    eta = done >= total_ ? "done" : "stopped";
  } else {
    eta = "ETA " + Duration(wrate > 0 ? (total_weight_ - w) / wrate : -1.0) +
          (weighted_ ? " (from the samples left)" : "");
  }
  const std::string stats = fmt::format("{}/{} {} ({:.1f} %), {:.1f}/s, elapsed {}, {}", done, total_, label_,
                                        100 * frac, rate, Duration(elapsed), eta);
  if (mode_ == Mode::kBar) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(frac * kWidth);
    std::fprintf(stderr, "\r[%s%s] %s\033[K%s", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kWidth - filled), ' ').c_str(), stats.c_str(),
                 final ? "\n" : "");
  } else {
    std::fprintf(stderr, "progress: %s\n", stats.c_str());
  }
  std::fflush(stderr);
}

StageProgress::StageProgress(std::string label, Progress::Mode mode, double delay, double line_interval)
    : label_(std::move(label)),
      mode_(mode),
      delay_(delay),
      line_interval_(line_interval),
      start_(std::chrono::steady_clock::now()),
      last_line_(start_) {
  if (mode_ == Progress::Mode::kAuto) mode_ = ::isatty(STDERR_FILENO) ? Progress::Mode::kBar : Progress::Mode::kNone;
  if (mode_ != Progress::Mode::kNone) thread_ = std::thread([this] { Loop(); });
}

StageProgress::~StageProgress() {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
    Erase();
  }
  cv_.notify_all();
  thread_.join();
}

void StageProgress::Stage(std::string stage) {
  const std::lock_guard lock(mutex_);
  stage_ = std::move(stage);
  fit_ = 0;
  iteration_ = -1;
}

void StageProgress::Iteration(int fit, int iteration, double cost) {
  const std::lock_guard lock(mutex_);
  fit_ = fit;
  iteration_ = iteration;
  cost_ = cost;
}

void StageProgress::Clear() {
  const std::lock_guard lock(mutex_);
  stage_.clear();
  Erase();
}

void StageProgress::Loop() {
  std::unique_lock lock(mutex_);
  while (!cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return stop_; })) Draw();
}

void StageProgress::Draw() {
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (stage_.empty() || elapsed < delay_) return;
  if (mode_ == Progress::Mode::kLines &&
      std::chrono::duration<double>(now - last_line_).count() < line_interval_) {
    return;
  }
  std::string text = fmt::format("{}: {}", label_, stage_);
  if (iteration_ >= 0) text += fmt::format(", fit {}, iteration {}, cost {:.6g}", fit_, iteration_, cost_);
  text += fmt::format(", elapsed {}", Duration(elapsed));
  if (mode_ == Progress::Mode::kBar) {
    std::fprintf(stderr, "\r%s\033[K", text.c_str());
    drawn_ = true;
  } else {
    std::fprintf(stderr, "progress: %s\n", text.c_str());
    last_line_ = now;
  }
  std::fflush(stderr);
}

void StageProgress::Erase() {
  if (!drawn_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace hysid
