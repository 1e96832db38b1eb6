#include "sspc/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string>

namespace sspc {
namespace {
constexpr std::int64_t kRedrawIntervalNs = 250'000'000;  // four refreshes a second

// 1234567 → "1.23 M", 850 → "850", 0.5 → "0.5"; three significant digits.
std::string si(double v) {
  static constexpr const char* kPrefixes[] = {"", " k", " M", " G", " T"};
  int p = 0;
  while (std::fabs(v) >= 1000.0 && p < 4) {
    v /= 1000.0;
    ++p;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g%s", v, kPrefixes[p]);
  return buf;
}

// "1.2 M points/s"; bytes as "35 MB/s".
std::string rate_text(double rate, std::string_view unit) {
  std::string s = si(rate);
  if (unit == "bytes")
    return s.append(std::isalpha(static_cast<unsigned char>(s.back())) ? "B/s" : " B/s");
  return s.append(" ").append(unit).append("/s");
}

std::string count_text(std::uint64_t n, std::string_view unit) {
  if (unit == "bytes") {
    std::string s = si(static_cast<double>(n));
    return s.append(std::isalpha(static_cast<unsigned char>(s.back())) ? "B" : " B");
  }
  return std::to_string(n).append(" ").append(unit);
}

// A finished stage's time: "0.47 s" under a minute, else as format_duration.
std::string seconds_text(double seconds) {
  if (!(seconds < 59.5)) return format_duration(seconds);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f s", seconds);
  return buf;
}

}  // namespace

void RateMeter::sample(double seconds, std::uint64_t done) {
  if (!started_) {
    started_ = true;
    last_seconds_ = seconds;
    last_done_ = done;
    return;
  }
  const double dt = seconds - last_seconds_;
  if (dt <= 0) return;
  const double instant = static_cast<double>(done - last_done_) / dt;
  // The first interval has no history to average with; afterwards each interval weighs by its
  // length, so that irregular redraws do not skew the average.
  const double alpha = rate_ == 0 ? 1.0 : 1.0 - std::exp(-dt / tau_);
  rate_ += alpha * (instant - rate_);
  last_seconds_ = seconds;
  last_done_ = done;
}

void RateMeter::reset() {
  *this = RateMeter(tau_);
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0 || seconds > 360000.0 * 24) return "--:--";
  const auto s = static_cast<long long>(std::llround(seconds));
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", s / 3600, (s / 60) % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%lld:%02lld", s / 60, s % 60);
  }
  return buf;
}

// Built with append: GCC 12 warns falsely (stringop-overflow) on "literal" + std::string here.
std::string format_progress_line(const ProgressLine& line) {
  std::string out;
  if (line.index > 0) {
    out.append("[").append(std::to_string(line.index));
    if (line.count > 0) out.append("/").append(std::to_string(std::max(line.count, line.index)));
    out.append("] ");
  }
  out.append(line.stage).append(":");
  if (line.finished) {
    const double average = line.elapsed > 0 ? static_cast<double>(line.done) / line.elapsed : 0.0;
    out.append(" ")
        .append(count_text(line.done, line.unit))
        .append(" in ")
        .append(seconds_text(line.elapsed));
    if (average > 0) out.append(" (").append(rate_text(average, line.unit)).append(")");
    return out;
  }
  if (line.total > 0) {
    char pct[16];
    const double percent =
        std::min(100.0, 100.0 * static_cast<double>(line.done) / static_cast<double>(line.total));
    std::snprintf(pct, sizeof pct, " %5.1f%%", percent);
    out.append(pct);
  } else {
    out.append(" ").append(count_text(line.done, line.unit));
  }
  if (line.rate > 0) out.append("  ").append(rate_text(line.rate, line.unit));
  if (line.total > 0) {
    const double left = line.done >= line.total ? 0.0
                        : line.rate > 0 ? static_cast<double>(line.total - line.done) / line.rate
                                        : -1.0;
    out.append("  ETA ").append(format_duration(left));
  } else {
    out.append("  ").append(format_duration(line.elapsed));
  }
  return out;
}

TerminalProgress::TerminalProgress(std::FILE* out)
    : TerminalProgress(out, out != nullptr && isatty(fileno(out)) != 0) {}

TerminalProgress::TerminalProgress(std::FILE* out, bool enabled) : out_(out), enabled_(enabled) {}

TerminalProgress::~TerminalProgress() {
  if (in_stage_) end_stage();
}

void TerminalProgress::set_stages(int count) {
  stage_count_ = count < 0 ? 0 : count;
}

void TerminalProgress::begin_stage(std::string_view name, std::uint64_t total,
                                   std::string_view unit) {
  if (in_stage_) end_stage();
  stage_ = std::string(name);
  unit_ = std::string(unit);
  total_ = total;
  ++stage_index_;
  done_.store(0, std::memory_order_relaxed);
  stage_start_ = Clock::now();
  next_draw_ns_.store(0, std::memory_order_relaxed);
  {
    std::lock_guard lock(draw_mutex_);
    rate_.reset();
    rate_.sample(0.0, 0);
  }
  in_stage_ = true;
  if (enabled_) {
    std::lock_guard lock(draw_mutex_);
    draw(false);
  }
}

void TerminalProgress::advance(std::uint64_t done) {
  done_.fetch_add(done, std::memory_order_relaxed);
  if (!enabled_) return;
  const std::int64_t now =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - stage_start_).count();
  std::int64_t next = next_draw_ns_.load(std::memory_order_relaxed);
  if (now < next) return;
  // One thread wins the right to draw; the others go back to work.
  if (!next_draw_ns_.compare_exchange_strong(next, now + kRedrawIntervalNs)) return;
  std::unique_lock lock(draw_mutex_, std::try_to_lock);
  if (lock.owns_lock()) draw(false);
}

void TerminalProgress::end_stage() {
  if (!in_stage_) return;
  in_stage_ = false;
  if (enabled_) {
    std::lock_guard lock(draw_mutex_);
    draw(true);
  }
}

// Called with draw_mutex_ held.
void TerminalProgress::draw(bool final_line) {
  const double seconds = std::chrono::duration<double>(Clock::now() - stage_start_).count();
  const std::uint64_t done = done_.load(std::memory_order_relaxed);
  rate_.sample(seconds, done);
  ProgressLine line;
  line.stage = stage_;
  line.index = stage_index_;
  line.count = stage_count_;
  line.done = done;
  line.total = total_;
  line.unit = unit_;
  line.rate = rate_.rate();
  line.elapsed = seconds;
  line.finished = final_line;
  const std::string text = format_progress_line(line);
  std::fprintf(out_, "\r\033[K%s", text.c_str());
  if (final_line) std::fputc('\n', out_);
  std::fflush(out_);
}

}  // namespace sspc
