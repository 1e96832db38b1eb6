#include "sspc/progress.hpp"

#include <unistd.h>

namespace sspc {
namespace {
constexpr std::int64_t kRedrawIntervalNs = 250'000'000;  // four refreshes a second
}

TerminalProgress::TerminalProgress(std::FILE* out)
    : TerminalProgress(out, out != nullptr && isatty(fileno(out)) != 0) {}

TerminalProgress::TerminalProgress(std::FILE* out, bool enabled) : out_(out), enabled_(enabled) {}

TerminalProgress::~TerminalProgress() {
  if (in_stage_) end_stage();
}

void TerminalProgress::begin_stage(std::string_view name, std::uint64_t total,
                                   std::string_view unit) {
  if (in_stage_) end_stage();
  stage_ = std::string(name);
  unit_ = std::string(unit);
  total_ = total;
  done_.store(0, std::memory_order_relaxed);
  stage_start_ = Clock::now();
  next_draw_ns_.store(0, std::memory_order_relaxed);
  in_stage_ = true;
  if (enabled_) draw(false);
}

void TerminalProgress::advance(std::uint64_t done) {
  done_.fetch_add(done, std::memory_order_relaxed);
  if (!enabled_) return;
  const std::int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                               Clock::now() - stage_start_).count();
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

void TerminalProgress::draw(bool final_line) {
  const double seconds = std::chrono::duration<double>(Clock::now() - stage_start_).count();
  const std::uint64_t done = done_.load(std::memory_order_relaxed);
  const double rate = seconds > 0 ? static_cast<double>(done) / seconds : 0.0;
  if (total_ > 0) {
    const double percent = 100.0 * static_cast<double>(done) / static_cast<double>(total_);
    std::fprintf(out_, "\r\033[K%s: %5.1f%%  %.3g %s/s  %.1f s", stage_.c_str(),
                 percent > 100.0 ? 100.0 : percent, rate, unit_.c_str(), seconds);
  } else {
    std::fprintf(out_, "\r\033[K%s: %llu %s  %.3g/s  %.1f s", stage_.c_str(),
                 static_cast<unsigned long long>(done), unit_.c_str(), rate, seconds);
  }
  if (final_line) std::fputc('\n', out_);
  std::fflush(out_);
}

}  // namespace sspc
