#include "core/atomic_file.hpp"
#include "core/mapped_file.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sspc/encoder.hpp"
#include "sspc/io.hpp"
#include "sspc/synthetic.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(AtomicFile, CommitReplacesTargetWhole) {
  test::TempDir dir;
  const auto target = dir.path() / "out.bin";
  { std::ofstream(target) << "old"; }
  AtomicFileWriter w;
  ASSERT_TRUE(w.open(target).ok());
  ASSERT_TRUE(w.write("new contents").ok());
  EXPECT_EQ(slurp(target), "old");  // nothing visible before commit
  ASSERT_TRUE(w.commit().ok());
  EXPECT_EQ(slurp(target), "new contents");
  EXPECT_EQ(test::count_files(dir.path()), 1u);  // no temporary left behind
}

TEST(AtomicFile, AbandonLeavesOldFileAndNoTemporary) {
  test::TempDir dir;
  const auto target = dir.path() / "out.bin";
  { std::ofstream(target) << "old"; }
  {
    AtomicFileWriter w;
    ASSERT_TRUE(w.open(target).ok());
    ASSERT_TRUE(w.write("partial").ok());
  }  // destroyed without commit, as on an error path
  EXPECT_EQ(slurp(target), "old");
  EXPECT_EQ(test::count_files(dir.path()), 1u);
}

TEST(AtomicFile, MissingDirectoryIsAnError) {
  test::TempDir dir;
  AtomicFileWriter w;
  Status s = w.open(dir.path() / "no" / "such" / "dir" / "f.bin");
  EXPECT_EQ(s.code(), StatusCode::kIoError);
}

// A full disk, simulated with a file-size limit (RLIMIT_FSIZE, no root needed): writes past it
// fail with EFBIG once SIGXFSZ is ignored, as remove_temporary_files_on_signals() does.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old_);
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = old_;
    limit.rlim_cur = bytes;
    EXPECT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_handler_);
  }
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

 private:
  rlimit old_{};
  void (*old_handler_)(int) = nullptr;
};

// Every writer (raw bytes, PLY, .sspc) on a full disk: an I/O error, the old file as it was,
// no temporary file left.
TEST(AtomicFile, AFullDiskLeavesTheOldFileAndNoTemporary) {
  test::TempDir dir;
  const auto target = dir.path() / "out";
  { std::ofstream(target) << "old"; }
  const PointCloud cloud = synthetic::sphere(3000, 1.0);
  // What the encoder writes without a limit, to choose a limit it exceeds.
  EncodeOptions options;
  options.level = 9;
  options.store_normals = true;
  options.full_spheres = true;
  const auto unlimited = dir.path() / "unlimited.sspc";
  auto stats = encode(cloud, unlimited, options);
  ASSERT_TRUE(stats.ok()) << stats.status().to_string();
  ASSERT_GT(stats->file_bytes, 2048u);
  std::filesystem::remove(unlimited);

  const FileSizeLimit limit(1024);
  const std::vector<std::byte> big(1 << 20, std::byte{7});
  const Status raw = write_file_atomically(target, big);
  EXPECT_EQ(raw.code(), StatusCode::kIoError) << raw.to_string();
  const Status ply = write_ply(cloud, target);
  EXPECT_EQ(ply.code(), StatusCode::kIoError) << ply.to_string();
  const auto encoded = encode(cloud, target, options);
  ASSERT_FALSE(encoded.ok());
  EXPECT_EQ(encoded.status().code(), StatusCode::kIoError) << encoded.status().to_string();
  EXPECT_EQ(slurp(target), "old");
  EXPECT_EQ(test::count_files(dir.path()), 1u);
}

// A process killed by SIGTERM or SIGINT in the middle of a write: the old file stays, and the
// handler remove_temporary_files_on_signals() installs removes the temporary file.
TEST(AtomicFile, ASignalLeavesTheOldFileAndNoTemporary) {
  for (const int sig : {SIGTERM, SIGINT}) {
    test::TempDir dir;
    const auto target = dir.path() / "out";
    { std::ofstream(target) << "old"; }
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      remove_temporary_files_on_signals();
      AtomicFileWriter w;
      if (!w.open(target).ok() || !w.write("half of the new").ok()) _exit(3);
      raise(sig);
      _exit(4);  // not reached
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << status;
    EXPECT_EQ(WTERMSIG(status), sig);
    EXPECT_EQ(slurp(target), "old");
    EXPECT_EQ(test::count_files(dir.path()), 1u);
  }
}

// A signal at any moment of a writer's life leaves no temporary file: a child opens and abandons
// writers in a loop until SIGINT stops it at some point of it. When the temporary file was
// created (mkstemp) before the handler knew of it, a signal that came while the creation was in
// the kernel ran the handler just after it, and the file stayed; now the name is registered
// before the file exists.
TEST(AtomicFile, ASignalAtAnyMomentLeavesNoTemporary) {
  for (int trial = 0; trial < 40; ++trial) {
    test::TempDir dir;
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      remove_temporary_files_on_signals();
      for (;;) {
        AtomicFileWriter w;
        if (!w.open(dir.path() / "out").ok()) _exit(3);
        auto scratch = TemporaryFile::create(dir.path(), "scratch-", ".ply");
        if (!scratch.ok()) _exit(3);
      }
    }
    usleep(static_cast<useconds_t>(2000 + 500 * (trial % 8)));
    ASSERT_EQ(kill(child, SIGINT), 0);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << status;
    EXPECT_EQ(test::count_files(dir.path()), 0u) << "trial " << trial;
  }
}

// SIGKILL (the OOM killer's signal) runs no handler: what the killed run was writing stays. A
// later run removes what it can lock (its owner is gone), never a live writer's or folder's, and
// names a staging folder that has no owner's file.
TEST(StaleTemporaries, AKilledRunsAreRemovedAndLiveOnesKept) {
  test::TempDir dir;
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    AtomicFileWriter w;
    StagingDirectory staging;
    if (!w.open(dir.path() / "model.sspc").ok() || !w.write("half").ok() || !staging.open(dir.path()).ok()) _exit(3);
    { std::ofstream(staging.stage(dir.path() / "tile")) << "staged points"; }
    raise(SIGKILL);
    _exit(4);  // not reached
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << status;
  ASSERT_EQ(test::count_files(dir.path()), 2u) << "the temporary and the staging folder";

  AtomicFileWriter live;
  ASSERT_TRUE(live.open(dir.path() / "live.sspc").ok());
  StagingDirectory live_staging;
  ASSERT_TRUE(live_staging.open(dir.path()).ok());
  std::filesystem::create_directory(dir.path() / ".sspc-staging-oldsspc");  // no owner's file
  // Younger than a minute: perhaps being made this moment, so kept.
  EXPECT_TRUE(remove_stale_temporaries(dir.path()).removed.empty());
  const StaleTemporaries found = remove_stale_temporaries(dir.path(), std::chrono::seconds(0));
  ASSERT_EQ(found.removed.size(), 2u);
  for (const auto& path : found.removed) EXPECT_FALSE(std::filesystem::exists(path)) << path;
  ASSERT_EQ(found.unknown.size(), 1u);
  EXPECT_EQ(found.unknown[0].filename(), ".sspc-staging-oldsspc");
  EXPECT_TRUE(std::filesystem::exists(live.temporary_path()));
  ASSERT_TRUE(live.write("whole").ok());
  ASSERT_TRUE(live.commit().ok());
  EXPECT_EQ(slurp(dir.path() / "live.sspc"), "whole");
  EXPECT_EQ(test::count_files(dir.path()), 3u) << "live.sspc, the live staging folder, the old sspc's folder";
}

// A TemporaryFile: its prefix and extension, a name of its own, gone when it is destroyed.
TEST(TemporaryFile, IsNamedAsAskedAndRemovedWhenDestroyed) {
  test::TempDir dir;
  std::filesystem::path first;
  {
    auto a = TemporaryFile::create(dir.path(), "sspc-stdout-", ".las");
    auto b = TemporaryFile::create(dir.path(), "sspc-stdout-", ".las");
    ASSERT_TRUE(a.ok() && b.ok());
    first = a->path();
    EXPECT_NE(a->path(), b->path());
    EXPECT_TRUE(std::filesystem::is_regular_file(a->path()));
    EXPECT_EQ(a->path().parent_path(), dir.path());
    EXPECT_EQ(a->path().extension(), ".las");
    EXPECT_EQ(a->path().filename().string().rfind("sspc-stdout-", 0), 0u);
    EXPECT_EQ(test::count_files(dir.path()), 2u);
  }
  EXPECT_FALSE(std::filesystem::exists(first));
  EXPECT_EQ(test::count_files(dir.path()), 0u);
  EXPECT_FALSE(TemporaryFile::create(dir.path() / "missing", "x-", "").ok());
}

TEST(MappedFile, MapsBytesAndReportsMissingFiles) {
  test::TempDir dir;
  const auto p = dir.path() / "data.bin";
  { std::ofstream(p, std::ios::binary) << "abc"; }
  auto m = MappedFile::open(p);
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->size(), 3u);
  EXPECT_EQ(static_cast<char>(m->bytes()[1]), 'b');
  auto missing = MappedFile::open(dir.path() / "absent");
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  auto directory = MappedFile::open(dir.path());
  EXPECT_EQ(directory.status().code(), StatusCode::kInvalidArgument);
}

TEST(MappedFile, EmptyFileMapsToEmptySpan) {
  test::TempDir dir;
  const auto p = dir.path() / "empty";
  { std::ofstream(p, std::ios::binary); }
  auto m = MappedFile::open(p);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->size(), 0u);
  EXPECT_TRUE(m->bytes().empty());
}

}  // namespace
}  // namespace sspc
