// Progress reporting for long operations.
//
// Library functions take an optional `Progress*`; they announce stages and advance a counter,
// from any thread. `TerminalProgress` draws a status line on stderr a few times a second when
// stderr is a terminal and prints nothing otherwise (the zstd CLI's behaviour):
//
//   [3/7] centres: repulsion and feature attraction  42.0%  1.2 k centres/s  ETA 03:10
//
// with the job's stage k of n, the rate over the last few seconds (not since the stage began:
// a stage that slows down shows it) in the caller's units, and the time left at that rate.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>

namespace sspc {

class Progress {
 public:
  virtual ~Progress() = default;
  // Starts a named stage of `total` work items (0: unknown) counted in `unit` ("points",
  // "patches"). Not thread-safe; call between parallel sections.
  virtual void begin_stage(std::string_view name, std::uint64_t total, std::string_view unit) = 0;
  // Adds `done` finished items to the current stage. Thread-safe and cheap.
  virtual void advance(std::uint64_t done) = 0;
  // Ends the current stage.
  virtual void end_stage() = 0;
  // Declares how many stages the whole job will begin, for a "stage k of n" display (0:
  // unknown). May be called again once the job knows more (after reading its input); stages
  // already begun still count. Optional: the default ignores it.
  virtual void set_stages(int /*count*/) {}
};

// Null-safe helpers so that callers need not test the pointer.
inline void progress_begin(Progress* p, std::string_view name, std::uint64_t total,
                           std::string_view unit = "points") {
  if (p != nullptr) p->begin_stage(name, total, unit);
}
inline void progress_advance(Progress* p, std::uint64_t done) {
  if (p != nullptr) p->advance(done);
}
inline void progress_end(Progress* p) {
  if (p != nullptr) p->end_stage();
}
inline void progress_stages(Progress* p, int count) {
  if (p != nullptr) p->set_stages(count);
}

// A rate over the last few seconds: an exponential moving average of the rate between samples,
// with time constant `tau_seconds`, so that the rate of a stage that slows down falls within
// seconds instead of being averaged with its fast start. Samples take the time explicitly, so a
// test can drive it with a fake clock.
class RateMeter {
 public:
  explicit RateMeter(double tau_seconds = 3.0) : tau_(tau_seconds) {}
  // `done` items finished by `seconds` since the stage began (both non-decreasing).
  void sample(double seconds, std::uint64_t done);
  // Items per second; 0 before two samples.
  double rate() const { return rate_; }
  void reset();

 private:
  double tau_;
  double last_seconds_ = 0;
  std::uint64_t last_done_ = 0;
  double rate_ = 0;
  bool started_ = false;
};

// What one status line shows.
struct ProgressLine {
  std::string_view stage;
  int index = 0;  // 1-based stage of the job; 0: not counted
  int count = 0;  // stages in the job; 0: unknown
  std::uint64_t done = 0;
  std::uint64_t total = 0;  // 0: unknown
  std::string_view unit;    // "points", "patches", "bytes", ...
  double rate = 0;          // units a second, recent
  double elapsed = 0;       // seconds since the stage began
  bool finished = false;    // the stage's last line: totals and the average rate
};

// "[k/n] stage: pct%  rate unit/s  ETA mm:ss" (see the top of this file); rates with SI
// prefixes ("1.2 M points/s", "35 MB/s" for bytes), ETA as m:ss or h:mm:ss, "--:--" while the
// rate is unknown.
std::string format_progress_line(const ProgressLine& line);
// 42 → "0:42", 3725 → "1:02:05"; negative or non-finite → "--:--".
std::string format_duration(double seconds);

class TerminalProgress final : public Progress {
 public:
  // `enabled` defaults to isatty(stderr); pass false to silence it.
  explicit TerminalProgress(std::FILE* out = stderr);
  TerminalProgress(std::FILE* out, bool enabled);
  ~TerminalProgress() override;

  void begin_stage(std::string_view name, std::uint64_t total, std::string_view unit) override;
  void advance(std::uint64_t done) override;
  void end_stage() override;
  void set_stages(int count) override;

  bool enabled() const { return enabled_; }

 private:
  using Clock = std::chrono::steady_clock;
  void draw(bool final_line);

  std::FILE* out_;
  bool enabled_;
  std::string stage_;
  std::string unit_;
  std::uint64_t total_ = 0;
  std::atomic<std::uint64_t> done_{0};
  std::atomic<std::int64_t> next_draw_ns_{0};
  Clock::time_point stage_start_;
  std::mutex draw_mutex_;
  RateMeter rate_;  // guarded by draw_mutex_
  bool in_stage_ = false;
  int stage_index_ = 0;
  int stage_count_ = 0;
};

}  // namespace sspc
