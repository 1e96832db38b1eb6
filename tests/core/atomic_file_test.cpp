#include "core/atomic_file.hpp"
#include "core/mapped_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

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
