// The progress line's text and its rate, driven by a fake clock.
#include <gtest/gtest.h>

#include <string>

#include "sspc/progress.hpp"

namespace sspc {
namespace {

TEST(Progress, LineShowsStageOfJobPercentRateAndEta) {
  ProgressLine line;
  line.stage = "code book: greedy clustering";
  line.index = 5;
  line.count = 7;
  line.done = 2500;
  line.total = 10000;
  line.unit = "patches";
  line.rate = 50;
  line.elapsed = 40;
  EXPECT_EQ(format_progress_line(line),
            "[5/7] code book: greedy clustering:  25.0%  50 patches/s  ETA 2:30");
}

TEST(Progress, RatesCarrySiPrefixesAndBytesAreBytes) {
  ProgressLine line;
  line.stage = "reading bunny.ply";
  line.index = 1;
  line.count = 1;
  line.done = 500;
  line.total = 1000;
  line.unit = "bytes";
  line.rate = 35.2e6;
  EXPECT_EQ(format_progress_line(line), "[1/1] reading bunny.ply:  50.0%  35.2 MB/s  ETA 0:00");
  line.unit = "points";
  line.rate = 1234567;
  line.done = 0;
  line.total = 3600 * 1234567ull;
  EXPECT_EQ(format_progress_line(line),
            "[1/1] reading bunny.ply:   0.0%  1.23 M points/s  ETA 1:00:00");
}

TEST(Progress, UnknownRateTotalOrCount) {
  ProgressLine line;
  line.stage = "render";
  line.index = 2;
  line.done = 0;
  line.total = 10;
  line.unit = "rows";
  EXPECT_EQ(format_progress_line(line), "[2] render:   0.0%  ETA --:--");
  line.total = 0;
  line.done = 12;
  line.elapsed = 75;
  line.rate = 2;
  EXPECT_EQ(format_progress_line(line), "[2] render: 12 rows  2 rows/s  1:15");
  line.index = 3;
  line.count = 2;  // a stage the job did not announce: n grows with k
  EXPECT_EQ(format_progress_line(line).substr(0, 6), "[3/3] ");
}

TEST(Progress, FinishedLineGivesTotalsAndTheAverage) {
  ProgressLine line;
  line.stage = "normals: PCA";
  line.index = 2;
  line.count = 4;
  line.done = 34834;
  line.total = 34834;
  line.unit = "points";
  line.elapsed = 2;
  line.finished = true;
  EXPECT_EQ(format_progress_line(line),
            "[2/4] normals: PCA: 34834 points in 2.00 s (17.4 k points/s)");
}

TEST(Progress, DurationsAsMinutesOrHours) {
  EXPECT_EQ(format_duration(0), "0:00");
  EXPECT_EQ(format_duration(42), "0:42");
  EXPECT_EQ(format_duration(600), "10:00");
  EXPECT_EQ(format_duration(3725), "1:02:05");
  EXPECT_EQ(format_duration(-1), "--:--");
}

// A stage that slows down: the cumulative average would still show most of the fast start; the
// recent rate falls to the slow one within a few time constants.
TEST(Progress, RateFollowsTheRecentPaceNotTheAverage) {
  RateMeter meter(3.0);
  EXPECT_EQ(meter.rate(), 0.0);
  std::uint64_t done = 0;
  double t = 0;
  meter.sample(t, done);
  for (int i = 0; i < 40; ++i) {  // 10 s at 1000 a second
    t += 0.25;
    done += 250;
    meter.sample(t, done);
  }
  EXPECT_NEAR(meter.rate(), 1000.0, 1e-6);
  for (int i = 0; i < 80; ++i) {  // then 20 s at 8 a second
    t += 0.25;
    done += 2;
    meter.sample(t, done);
  }
  const double cumulative = static_cast<double>(done) / t;
  EXPECT_GT(cumulative, 300.0);
  EXPECT_LT(meter.rate(), 20.0);
  EXPECT_GT(meter.rate(), 7.0);
}

TEST(Progress, TerminalProgressCountsStagesAndStaysQuietWhenDisabled) {
  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  {
    TerminalProgress progress(out, true);
    progress.set_stages(2);
    progress.begin_stage("first", 4, "points");
    progress.advance(4);
    progress.end_stage();
    progress.begin_stage("second", 0, "patches");
    progress.end_stage();
  }
  std::rewind(out);
  std::string text;
  for (int c = std::fgetc(out); c != EOF; c = std::fgetc(out)) text += static_cast<char>(c);
  std::fclose(out);
  EXPECT_NE(text.find("[1/2] first:"), std::string::npos) << text;
  EXPECT_NE(text.find("[2/2] second:"), std::string::npos) << text;

  std::FILE* quiet = std::tmpfile();
  ASSERT_NE(quiet, nullptr);
  {
    TerminalProgress progress(quiet, false);
    progress.begin_stage("first", 4, "points");
    progress.advance(4);
  }
  EXPECT_EQ(std::ftell(quiet), 0L);
  std::fclose(quiet);
}

}  // namespace
}  // namespace sspc
