#include "core/atomic_file.hpp"

#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace sspc {

namespace {
std::string errno_text() { return std::strerror(errno); }

// The temporary files being written, for the signal handler: fixed storage and atomic flags,
// because a handler may only call async-signal-safe functions (unlink) and read lock-free data.
// A writer whose path does not fit, or that finds every slot taken, is simply not registered.
constexpr int kTempSlots = 64;
constexpr std::size_t kTempPathMax = 4096;
struct TempSlot {
  std::atomic<bool> taken{false};  // owned by a writer
  std::atomic<bool> live{false};   // path is complete and the file may exist
  std::atomic<bool> folder{false};  // path is a StagingDirectory: empty it, then remove it
  char path[kTempPathMax];
};
TempSlot g_temp_slots[kTempSlots];

int register_temporary(const std::filesystem::path& path, bool folder = false) {
  const std::string& s = path.native();
  if (s.size() >= kTempPathMax) return -1;
  for (int i = 0; i < kTempSlots; ++i) {
    TempSlot& slot = g_temp_slots[i];
    bool expected = false;
    if (!slot.taken.compare_exchange_strong(expected, true)) continue;
    std::memcpy(slot.path, s.c_str(), s.size() + 1);
    slot.folder.store(folder, std::memory_order_relaxed);
    slot.live.store(true, std::memory_order_release);
    return i;
  }
  return -1;
}

void unregister_temporary(int i) {
  if (i < 0) return;
  g_temp_slots[i].live.store(false, std::memory_order_release);
  g_temp_slots[i].taken.store(false, std::memory_order_release);
}

// Six characters (letters and digits) that differ from call to call and from process to process.
std::string random_suffix() {
  static std::atomic<std::uint64_t> counter{0};
  struct timespec now {};
  clock_gettime(CLOCK_MONOTONIC, &now);
  std::uint64_t x = (static_cast<std::uint64_t>(getpid()) << 40) ^ (counter.fetch_add(1) << 20) ^
                    static_cast<std::uint64_t>(now.tv_nsec) ^ (static_cast<std::uint64_t>(now.tv_sec) << 32);
  // splitmix64's finaliser: every input bit reaches every character.
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  x ^= x >> 31;
  constexpr char kChars[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
  std::string suffix(6, 'X');
  for (char& c : suffix) {
    c = kChars[x % 62];
    x /= 62;
  }
  return suffix;
}

// Creates `prefix` + six random characters + `extension`, a file (its descriptor returned, open
// for writing) or a folder (0 returned), registered for the signal handler before it exists, so that no
// moment passes with the file there and unknown to the handler: with mkstemp and then the
// registration, a signal that arrived while mkstemp's open() was in the kernel ran the handler
// between the two and the file stayed (an interrupted `sspc normals` left one on a loaded
// machine). A name already taken is never registered (the handler would remove another's file):
// another is tried. -1 with errno set on failure.
int create_registered(const std::string& prefix, bool folder, std::string& name, int& slot,
                      const std::string& extension = "") {
  for (int attempt = 0; attempt < 100; ++attempt) {
    name = prefix + random_suffix() + extension;
    struct stat st {};
    if (lstat(name.c_str(), &st) == 0) continue;
    slot = register_temporary(name, folder);
    const int fd = folder ? mkdir(name.c_str(), 0700) : ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd >= 0) {
      // Held while the file is open: a later run that can take it knows its writer is gone
      // (remove_stale_temporaries). A brand-new file's lock is free.
      if (!folder) flock(fd, LOCK_EX | LOCK_NB);
      return fd;
    }
    const int error = errno;
    unregister_temporary(slot);
    slot = -1;
    if (error != EEXIST) {
      errno = error;
      return -1;
    }
  }
  errno = EEXIST;
  return -1;
}

// Removes every entry of the folder `path` (files only: a StagingDirectory holds no folders),
// then the folder, with system calls alone, as a signal handler may.
void remove_folder_in_handler(const char* path) {
  const int fd = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    alignas(8) char buffer[4096];
    for (;;) {
      const long n = syscall(SYS_getdents64, fd, buffer, sizeof buffer);
      if (n <= 0) break;
      for (long at = 0; at < n;) {
        struct Entry {
          std::uint64_t inode;
          std::int64_t offset;
          unsigned short length;
          unsigned char type;
          char name[1];
        };
        const auto* e = reinterpret_cast<const Entry*>(buffer + at);
        const bool dot = e->name[0] == '.' && (e->name[1] == '\0' || (e->name[1] == '.' && e->name[2] == '\0'));
        if (!dot) unlinkat(fd, e->name, 0);
        at += e->length;
      }
    }
    ::close(fd);
  }
  rmdir(path);
}

extern "C" void remove_temporaries_and_reraise(int sig) {
  for (TempSlot& slot : g_temp_slots) {
    if (!slot.live.load(std::memory_order_acquire)) continue;
    if (slot.folder.load(std::memory_order_relaxed)) {
      remove_folder_in_handler(slot.path);
    } else {
      unlink(slot.path);
    }
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}
}  // namespace

void remove_temporary_files_on_signals() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction action {};
    action.sa_handler = remove_temporaries_and_reraise;
    sigemptyset(&action.sa_mask);
    sigaction(sig, &action, nullptr);
  }
  std::signal(SIGXFSZ, SIG_IGN);
}

AtomicFileWriter::~AtomicFileWriter() { abandon(); }

Status AtomicFileWriter::open(const std::filesystem::path& target) {
  abandon();
  target_ = target;
  std::filesystem::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  // "." + name + ".tmp-XXXXXX", the name shortened so that the whole stays within NAME_MAX
  // (a 250-byte target name is legal; its temporary name must be too).
  constexpr std::size_t kSuffix = 12;  // "." and ".tmp-XXXXXX"
  std::string stem = target.filename().string();
  if (stem.size() + kSuffix > NAME_MAX) stem.resize(NAME_MAX - kSuffix);
  std::string name;
  const int fd = create_registered((dir / ("." + stem + ".tmp-")).string(), false, name, slot_);
  if (fd < 0) {
    return io_error(target.string() + ": cannot create a temporary file in " + dir.string() +
                    ": " + errno_text());
  }
  temp_ = name;
  file_ = fdopen(fd, "wb");
  if (file_ == nullptr) {
    close(fd);
    std::filesystem::remove(temp_);
    temp_.clear();
    unregister_temporary(slot_);
    slot_ = -1;
    return io_error(target.string() + ": " + errno_text());
  }
  return Status();
}

Status AtomicFileWriter::write(const void* data, std::size_t size) {
  if (file_ == nullptr) return internal_error("AtomicFileWriter::write before open");
  if (size == 0) return Status();
  if (std::fwrite(data, 1, size, file_) != size) {
    const std::string why = errno_text();
    abandon();
    return io_error(target_.string() + ": write failed: " + why);
  }
  return Status();
}

Status AtomicFileWriter::flush() {
  if (file_ == nullptr) return internal_error("AtomicFileWriter::flush before open");
  if (std::fflush(file_) != 0) {
    const std::string why = errno_text();
    abandon();
    return io_error(target_.string() + ": write failed: " + why);
  }
  return Status();
}

Status AtomicFileWriter::write_at(std::uint64_t offset, std::string_view bytes) {
  SSPC_RETURN_IF_ERROR(flush());
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = pwrite(fileno(file_), bytes.data() + done, bytes.size() - done,
                             static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? errno_text() : "no progress";
      abandon();
      return io_error(target_.string() + ": write failed: " + why);
    }
    done += static_cast<std::size_t>(n);
  }
  return Status();
}

Status AtomicFileWriter::commit() {
  if (file_ == nullptr) return internal_error("AtomicFileWriter::commit before open");
  if (std::fflush(file_) != 0 || fsync(fileno(file_)) != 0) {
    const std::string why = errno_text();
    abandon();
    return io_error(target_.string() + ": write failed: " + why);
  }
  // mkstemp creates 0600; give the file the permissions an ordinary new file would get.
  const mode_t mask = umask(0);
  umask(mask);
  if (fchmod(fileno(file_), 0666 & ~mask) != 0) {
    // Not fatal: the data is intact, only its permissions stay 0600.
  }
  // Renamed while still open, so that its lock holds until it is the target: closed first, a
  // concurrent run's remove_stale_temporaries could take it for an interrupted run's.
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) {
    abandon();
    return io_error(target_.string() + ": cannot rename the temporary file: " + ec.message());
  }
  temp_.clear();
  unregister_temporary(slot_);
  slot_ = -1;
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) return io_error(target_.string() + ": close failed: " + errno_text());
  return Status();
}

void AtomicFileWriter::abandon() {
  if (file_ != nullptr) {
    std::fclose(file_);
    file_ = nullptr;
  }
  if (!temp_.empty()) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
    temp_.clear();
  }
  unregister_temporary(slot_);
  slot_ = -1;
}

StatusOr<TemporaryFile> TemporaryFile::create(const std::filesystem::path& dir, const std::string& prefix,
                                               const std::string& extension) {
  TemporaryFile file;
  std::string name;
  const int fd = create_registered((dir / prefix).string(), false, name, file.slot_, extension);
  if (fd < 0) return io_error(dir.string() + ": cannot create a temporary file: " + errno_text());
  ::close(fd);
  file.path_ = name;
  return file;
}

TemporaryFile::TemporaryFile(TemporaryFile&& other) noexcept
    : path_(std::exchange(other.path_, {})), slot_(std::exchange(other.slot_, -1)) {}

TemporaryFile::~TemporaryFile() {
  if (!path_.empty()) {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  unregister_temporary(slot_);
}

StagingDirectory::~StagingDirectory() { abandon(); }

Status StagingDirectory::open(const std::filesystem::path& dir) {
  abandon();
  const std::filesystem::path where = dir.empty() ? std::filesystem::path(".") : dir;
  std::string name;
  if (create_registered((where / ".sspc-staging-").string(), true, name, slot_) < 0) {
    return io_error(where.string() + ": cannot create a temporary folder: " + errno_text());
  }
  dir_ = name;
  // The owner's lock, held until the folder is removed: a later run that can take it knows the
  // run that made the folder is gone, whatever killed it (remove_stale_temporaries).
  const std::string owner = (dir_ / kOwnerName).string();
  lock_fd_ = ::open(owner.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (lock_fd_ < 0 || flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const std::string why = errno_text();
    abandon();
    return io_error(where.string() + ": cannot lock a temporary folder: " + why);
  }
  const std::string pid = std::to_string(getpid()) + "\n";
  if (::write(lock_fd_, pid.data(), pid.size()) < 0) {
    // Informative only: the lock is what marks the owner.
  }
  return Status();
}

std::filesystem::path StagingDirectory::stage(const std::filesystem::path& target) {
  std::filesystem::path staged = dir_ / target.filename();
  staged_.emplace_back(staged, target);
  return staged;
}

Status StagingDirectory::commit() {
  if (dir_.empty()) return internal_error("StagingDirectory::commit before open");
  for (const auto& [staged, target] : staged_) {
    std::error_code ec;
    std::filesystem::rename(staged, target, ec);
    if (ec) {
      const std::string why = ec.message();
      abandon();
      return io_error(target.string() + ": cannot move the finished file into place: " + why);
    }
  }
  staged_.clear();
  abandon();
  return Status();
}

void StagingDirectory::abandon() {
  if (!dir_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
    dir_.clear();
  }
  if (lock_fd_ >= 0) {
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  staged_.clear();
  unregister_temporary(slot_);
  slot_ = -1;
}

namespace {

// Whether `path`'s lock can be taken: nobody holds it, so the process that made it is gone. The
// lock is released again at once (closing the descriptor).
bool lock_is_free(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return false;
  const bool free = flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);
  return free;
}

bool is_temporary_file_name(const std::string& name) {
  // "." + target + ".tmp-" + six characters (AtomicFileWriter::open).
  constexpr std::string_view kTag = ".tmp-";
  return name.size() > 1 + kTag.size() + 6 && name[0] == '.' &&
         name.compare(name.size() - 6 - kTag.size(), kTag.size(), kTag) == 0;
}

}  // namespace

StaleTemporaries remove_stale_temporaries(const std::filesystem::path& dir, std::chrono::seconds min_age) {
  StaleTemporaries found;
  std::error_code ec;
  const auto now = std::filesystem::file_time_type::clock::now();
  for (std::filesystem::directory_iterator it(dir.empty() ? "." : dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::filesystem::path& path = it->path();
    const std::string name = path.filename().string();
    const bool folder = name.starts_with(".sspc-staging-") && it->is_directory(ec);
    const bool file = !folder && is_temporary_file_name(name) && it->is_regular_file(ec);
    if (!folder && !file) continue;
    const auto modified = std::filesystem::last_write_time(path, ec);
    if (ec || now - modified < min_age) continue;  // perhaps being made this moment
    if (folder && !std::filesystem::exists(path / StagingDirectory::kOwnerName, ec)) {
      found.unknown.push_back(path);  // a folder of an sspc that did not lock its folders
      continue;
    }
    if (!lock_is_free(folder ? path / StagingDirectory::kOwnerName : path)) continue;  // in use
    std::error_code removed;
    std::filesystem::remove_all(path, removed);
    if (!removed) found.removed.push_back(path);
  }
  return found;
}

Status write_file_atomically(const std::filesystem::path& target, std::span<const std::byte> bytes) {
  AtomicFileWriter writer;
  SSPC_RETURN_IF_ERROR(writer.open(target));
  SSPC_RETURN_IF_ERROR(writer.write(bytes.data(), bytes.size()));
  return writer.commit();
}

}  // namespace sspc
