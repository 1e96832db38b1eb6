// MappedFile: what it refuses to map, and what happens when the file shrinks under a mapping.
#include "core/mapped_file.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

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

}  // namespace
}  // namespace sspc
