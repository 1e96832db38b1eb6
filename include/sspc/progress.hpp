// Progress reporting for long operations.
//
// Library functions take an optional `Progress*`; they announce stages and advance a counter,
// from any thread. `TerminalProgress` draws a status line on stderr a few times a second when
// stderr is a terminal and prints nothing otherwise (the zstd CLI's behaviour).
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

class TerminalProgress final : public Progress {
 public:
  // `enabled` defaults to isatty(stderr); pass false to silence it.
  explicit TerminalProgress(std::FILE* out = stderr);
  TerminalProgress(std::FILE* out, bool enabled);
  ~TerminalProgress() override;

  void begin_stage(std::string_view name, std::uint64_t total, std::string_view unit) override;
  void advance(std::uint64_t done) override;
  void end_stage() override;

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
  bool in_stage_ = false;
};

}  // namespace sspc
