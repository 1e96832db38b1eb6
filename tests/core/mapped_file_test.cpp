// MappedFile: what it refuses to map, and what happens when the file shrinks under a mapping.
#include "core/mapped_file.hpp"

#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "test_util.hpp"

namespace sspc {
namespace {

// Kills the test process if a call blocks (an open() that waits for a FIFO's writer would
// otherwise hang the suite until CTest's timeout).
class Watchdog {
 public:
  explicit Watchdog(unsigned seconds) { alarm(seconds); }
  ~Watchdog() { alarm(0); }
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;
};

void expect_refused(const std::filesystem::path& path, const std::string& kind) {
  const Watchdog watchdog(10);
  const StatusOr<MappedFile> file = MappedFile::open(path);
  ASSERT_FALSE(file.ok()) << path;
  EXPECT_EQ(file.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(file.status().message(), path.string() + ": not a regular file (" + kind + ")");
}

TEST(MappedFile, AFifoIsRefusedAtOnceInsteadOfWaitingForAWriter) {
  test::TempDir dir;
  const auto path = dir.path() / "pipe.ply";
  ASSERT_EQ(mkfifo(path.c_str(), 0600), 0);
  expect_refused(path, "a FIFO");
}

TEST(MappedFile, OtherKindsOfFileAreNamed) {
  test::TempDir dir;
  expect_refused(dir.path(), "a directory");
  expect_refused("/dev/null", "a character device");

  const auto socket_path = dir.path() / "s.ply";
  const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  ASSERT_LT(socket_path.native().size(), sizeof address.sun_path);
  socket_path.native().copy(address.sun_path, socket_path.native().size());
  ASSERT_EQ(bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  expect_refused(socket_path, "a socket");
  close(fd);
}

TEST(MappedFile, ARegularFileStillMaps) {
  test::TempDir dir;
  const auto path = dir.path() / "a.txt";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fputs("1 2 3\n", f);
  std::fclose(f);
  const StatusOr<MappedFile> file = MappedFile::open(path);
  ASSERT_TRUE(file.ok()) << file.status().to_string();
  EXPECT_EQ(file->size(), 6u);
}

// A file of `bytes` bytes, none of them zero.
std::filesystem::path write_pattern_file(const test::TempDir& dir, std::size_t bytes,
                                         const char* name = "shrinking.bin") {
  const auto path = dir.path() / name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  for (std::size_t i = 0; i < bytes; ++i) std::fputc(static_cast<int>(1 + i % 251), f);
  std::fclose(f);
  return path;
}

std::size_t page_size() {
  return static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

// Reads every byte of the mapping; those past `kept` must read as zero, those before it as
// written.
void expect_pattern_then_zeros(const MappedFile& file, std::size_t kept) {
  const std::span<const std::byte> bytes = file.bytes();
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const auto expected = i < kept ? static_cast<std::byte>(1 + i % 251) : std::byte{0};
    if (bytes[i] != expected) ++wrong;
  }
  EXPECT_EQ(wrong, 0u);
}

TEST(MappedFile, AnIntactFileIsIntact) {
  test::TempDir dir;
  const auto path = write_pattern_file(dir, 3 * page_size());
  const StatusOr<MappedFile> file = MappedFile::open(path);
  ASSERT_TRUE(file.ok()) << file.status().to_string();
  expect_pattern_then_zeros(*file, file->size());
  EXPECT_FALSE(file->truncated());
  EXPECT_TRUE(file->check_intact().ok());
}

// Pages wholly past the new end fault (SIGBUS) when touched; the mapping serves zeros for them
// and remembers it. Before, the process died with SIGBUS and no message.
TEST(MappedFile, ReadingPastTheEndOfAFileThatShrankGivesZerosAndAnError) {
  test::TempDir dir;
  const std::size_t size = 5 * page_size();
  const auto path = write_pattern_file(dir, size);
  StatusOr<MappedFile> file = MappedFile::open(path);
  ASSERT_TRUE(file.ok()) << file.status().to_string();
  const std::size_t kept = page_size() + page_size() / 2;
  ASSERT_EQ(truncate(path.c_str(), static_cast<off_t>(kept)), 0);
  expect_pattern_then_zeros(*file, kept);
  EXPECT_TRUE(file->truncated());
  const Status status = file->check_intact();
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_EQ(status.message(), path.string() + ": the file shrank while it was read (was " +
                                  std::to_string(size) + " bytes)");

  // The mapping moves with its owner, and a second mapping of the same file is not affected
  // by what happened to the first.
  const MappedFile moved = std::move(file).value();
  EXPECT_TRUE(moved.truncated());
  ASSERT_EQ(truncate(path.c_str(), static_cast<off_t>(size)), 0);
  const StatusOr<MappedFile> again = MappedFile::open(path);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->truncated());
}

// A file that shrinks inside its last page raises no SIGBUS (the kernel zero-fills the rest of
// a page that holds the end of the file), so the size is checked too.
TEST(MappedFile, AFileThatShrankWithinItsLastPageIsNoticed) {
  test::TempDir dir;
  const std::size_t size = page_size() - 10;
  const auto path = write_pattern_file(dir, size);
  const StatusOr<MappedFile> file = MappedFile::open(path);
  ASSERT_TRUE(file.ok());
  ASSERT_EQ(truncate(path.c_str(), 100), 0);
  expect_pattern_then_zeros(*file, 100);
  EXPECT_TRUE(file->truncated());
  EXPECT_FALSE(file->check_intact().ok());
}

// However many files are open, none is read through an unguarded mapping: past the handler's
// table, the bytes are copied instead, and a copy cannot fault.
TEST(MappedFile, ManyOpenFilesAreAllSafeFromTruncation) {
  test::TempDir dir;
  const std::size_t size = 3 * page_size();
  const auto path = write_pattern_file(dir, size);
  std::vector<MappedFile> files;
  for (int i = 0; i < 300; ++i) {
    StatusOr<MappedFile> file = MappedFile::open(path);
    ASSERT_TRUE(file.ok()) << file.status().to_string();
    files.push_back(std::move(file).value());
  }
  ASSERT_EQ(truncate(path.c_str(), 10), 0);
  for (const MappedFile& file : files) {
    ASSERT_EQ(file.size(), size);
    std::size_t nonzero = 0;
    for (const std::byte b : file.bytes()) nonzero += b != std::byte{0} ? 1 : 0;
    // A guarded mapping serves zeros past the new end and says so; a copy keeps every byte.
    if (nonzero == size) continue;
    EXPECT_EQ(nonzero, 10u);
    EXPECT_FALSE(file.check_intact().ok());
  }
}

// The handler only handles faults inside MappedFile's mappings; every other SIGBUS goes where it
// went before. Each case runs in a fresh process ("threadsafe" death tests re-execute the test
// binary), so that the test's own handler is installed before MappedFile installs its own.
class MappedFileSignals : public ::testing::Test {
 protected:
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

// The default disposition, whatever a sanitizer's runtime installed at start-up.
void default_sigbus() {
  struct sigaction action {};
  action.sa_handler = SIG_DFL;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, nullptr);
}

// A death test's child runs the test's body again, so it has a TempDir of its own, which it
// removes before it dies (its destructor never runs): 42 such folders were left in /tmp before.
void remove_before_dying(const test::TempDir& dir) {
  std::error_code ec;
  std::filesystem::remove_all(dir.path(), ec);
}

// Opens a MappedFile of a file in `dir` and then removes `dir`: the handler is installed.
void open_some_mapping(const test::TempDir& dir) {
  const auto path = write_pattern_file(dir, 100, "some.bin");
  const StatusOr<MappedFile> file = MappedFile::open(path);
  if (!file.ok()) std::_Exit(3);
  remove_before_dying(dir);
}

TEST_F(MappedFileSignals, AnotherSigbusStillKillsTheProcess) {
  test::TempDir dir;
  EXPECT_EXIT(
      {
        default_sigbus();
        open_some_mapping(dir);
        raise(SIGBUS);
      },
      ::testing::KilledBySignal(SIGBUS), "");
}

TEST_F(MappedFileSignals, AFaultInAMappingOfSomeoneElseStillKillsTheProcess) {
  test::TempDir dir;
  EXPECT_EXIT(
      {
        default_sigbus();
        const auto path = write_pattern_file(dir, 3 * page_size());
        const int fd = ::open(path.c_str(), O_RDWR);
        const auto* p = static_cast<const volatile char*>(
            mmap(nullptr, 3 * page_size(), PROT_READ, MAP_PRIVATE, fd, 0));
        open_some_mapping(dir);  // removes the folder; the descriptor keeps the file
        if (ftruncate(fd, 0) != 0) std::_Exit(3);
        std::_Exit(p[2 * page_size()]);
      },
      ::testing::KilledBySignal(SIGBUS), "");
}

extern "C" void exit_42(int) {
  std::_Exit(42);
}

TEST_F(MappedFileSignals, AHandlerInstalledBeforeIsChainedTo) {
  test::TempDir dir;
  EXPECT_EXIT(
      {
        struct sigaction action {};
        action.sa_handler = exit_42;
        sigemptyset(&action.sa_mask);
        sigaction(SIGBUS, &action, nullptr);
        open_some_mapping(dir);
        raise(SIGBUS);
      },
      ::testing::ExitedWithCode(42), "");
}

}  // namespace
}  // namespace sspc
