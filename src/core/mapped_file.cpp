#include "core/mapped_file.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <string>
#include <utility>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

namespace sspc {

namespace {

// The live mappings, for the SIGBUS handler: fixed storage and lock-free atomics, because a
// handler may only read such data. `end` is written last on registration and cleared first on
// removal, so a handler that sees a non-zero `end` also sees the matching `begin`.
constexpr int kMappingSlots = 256;
struct MappingSlot {
  std::atomic<bool> taken{false};
  std::atomic<std::uintptr_t> begin{0};
  std::atomic<std::uintptr_t> end{0};  // 0 while the slot holds no mapping
  std::atomic<bool> faulted{false};    // a page of zeros replaced part of the file
};
static_assert(std::atomic<std::uintptr_t>::is_always_lock_free);
static_assert(std::atomic<bool>::is_always_lock_free);
MappingSlot g_mappings[kMappingSlots];

std::uintptr_t g_page_size = 4096;  // set before the handler is installed
struct sigaction g_previous_sigbus {};

int register_mapping(const std::byte* data, std::size_t size) {
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  for (int i = 0; i < kMappingSlots; ++i) {
    MappingSlot& slot = g_mappings[i];
    bool expected = false;
    if (!slot.taken.compare_exchange_strong(expected, true)) continue;
    slot.faulted.store(false);
    slot.begin.store(begin);
    slot.end.store(begin + size, std::memory_order_release);
    return i;
  }
  return -1;
}

void unregister_mapping(int i) {
  if (i < 0) return;
  g_mappings[i].end.store(0, std::memory_order_release);
  g_mappings[i].begin.store(0);
  g_mappings[i].taken.store(false, std::memory_order_release);
}

// The signal goes where it would have gone without sspc.
void pass_on(int sig, siginfo_t* info, void* context) {
  const struct sigaction& previous = g_previous_sigbus;
  if ((previous.sa_flags & SA_SIGINFO) != 0) {
    if (previous.sa_sigaction != nullptr) previous.sa_sigaction(sig, info, context);
    return;
  }
  if (previous.sa_handler == SIG_IGN && info->si_code <= 0) return;  // sent, and ignored
  if (previous.sa_handler == SIG_DFL || previous.sa_handler == SIG_IGN) {
    // The default action (a fault cannot be ignored: the instruction would fault forever). The
    // re-raised signal is blocked until this handler returns, then ends the process.
    struct sigaction fallback {};
    fallback.sa_handler = SIG_DFL;
    sigemptyset(&fallback.sa_mask);
    sigaction(sig, &fallback, nullptr);
    raise(sig);
    return;
  }
  previous.sa_handler(sig);
}

extern "C" void on_sigbus(int sig, siginfo_t* info, void* context) {
  const int saved_errno = errno;
  // si_code > 0: raised by the kernel for a fault at si_addr (not sent with kill or raise).
  if (info != nullptr && info->si_code > 0) {
    const auto address = reinterpret_cast<std::uintptr_t>(info->si_addr);
    for (MappingSlot& slot : g_mappings) {
      const std::uintptr_t end = slot.end.load(std::memory_order_acquire);
      if (address >= end || address < slot.begin.load()) continue;
      // The flag first: whoever reads the zeros this mapping now serves, in this thread or
      // another, finds it set when it checks afterwards.
      slot.faulted.store(true);
      void* page = reinterpret_cast<void*>(address & ~(g_page_size - 1));
      if (mmap(page, g_page_size, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) !=
          MAP_FAILED) {
        errno = saved_errno;
        return;  // the faulting read is retried and finds zeros
      }
      break;
    }
  }
  errno = saved_errno;
  pass_on(sig, info, context);
}

void install_sigbus_handler() {
  static std::once_flag once;
  std::call_once(once, [] {
    g_page_size = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    sigaction(SIGBUS, nullptr, &g_previous_sigbus);
    struct sigaction action {};
    action.sa_sigaction = on_sigbus;
    action.sa_flags = SA_SIGINFO | SA_ONSTACK;
    sigemptyset(&action.sa_mask);
    sigaction(SIGBUS, &action, nullptr);
  });
}

std::string shrank_message(const std::filesystem::path& path, std::size_t size) {
  return path.string() + ": the file shrank while it was read (was " + std::to_string(size) +
         " bytes)";
}

// What a path that is not a regular file is, for the message.
const char* file_kind(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISDIR(mode)) return "a directory";
  return "not a file sspc can map";
}

Status not_regular(const std::filesystem::path& path, mode_t mode) {
  return invalid_argument(path.string() + ": not a regular file (" + file_kind(mode) + ")");
}

// Opens `path` for reading if it is a regular file, without ever blocking.
StatusOr<int> open_regular_file(const std::filesystem::path& path, struct stat& st) {
  // O_NONBLOCK: opening a FIFO for reading otherwise waits for a writer, possibly forever,
  // before the file's kind can be checked. O_NOCTTY: a terminal device must not become the
  // process's controlling terminal on the way to being refused.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT) return not_found(path.string() + ": no such file");
    // A socket cannot be opened at all (ENXIO); say what it is rather than what open() says.
    if (err == ENXIO && ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
      return not_regular(path, st.st_mode);
    }
    return io_error(path.string() + ": cannot open: " + std::strerror(err));
  }
  if (fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return io_error(path.string() + ": cannot stat: " + std::strerror(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return not_regular(path, st.st_mode);
  }
  // Reads of a regular file never block, but the descriptor should not carry a flag that
  // changes how it behaves for whoever reads through it later.
  const int flags = fcntl(fd, F_GETFL);
  if (flags < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
    const int err = errno;
    ::close(fd);
    return io_error(path.string() + ": cannot clear O_NONBLOCK: " + std::strerror(err));
  }
  return fd;
}

// The whole file read into memory, for when no slot is free to guard a mapping.
Status read_all(int fd, const std::filesystem::path& path, std::byte* out, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = pread(fd, out + done, size - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return io_error(path.string() + ": read failed: " + std::strerror(errno));
    if (n == 0) return io_error(shrank_message(path, size));
    done += static_cast<std::size_t>(n);
  }
  return Status();
}

}  // namespace

MappedFile::MappedFile(MappedFile&& other) noexcept
    : path_(std::move(other.path_)),
      data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      slot_(std::exchange(other.slot_, -1)),
      fd_(std::exchange(other.fd_, -1)),
      copy_(std::move(other.copy_)) {}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
  if (this != &other) {
    reset();
    path_ = std::move(other.path_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    slot_ = std::exchange(other.slot_, -1);
    fd_ = std::exchange(other.fd_, -1);
    copy_ = std::move(other.copy_);
  }
  return *this;
}

MappedFile::~MappedFile() {
  reset();
}

void MappedFile::reset() {
  // Out of the handler's table before the pages go, so that it never patches an address range
  // that something else may map next.
  unregister_mapping(std::exchange(slot_, -1));
  if (data_ != nullptr && size_ > 0 && copy_ == nullptr) {
    munmap(const_cast<std::byte*>(data_), size_);
  }
  copy_.reset();
  if (fd_ >= 0) ::close(std::exchange(fd_, -1));
  data_ = nullptr;
  size_ = 0;
}

bool MappedFile::truncated() const {
  if (slot_ >= 0 && g_mappings[slot_].faulted.load()) return true;
  struct stat st {};
  return fd_ >= 0 && fstat(fd_, &st) == 0 && static_cast<std::uintmax_t>(st.st_size) < size_;
}

Status MappedFile::check_intact() const {
  if (truncated()) return io_error(shrank_message(path_, size_));
  return Status();
}

void MappedFile::release(std::size_t begin, std::size_t end) const {
  if (copy_ != nullptr || data_ == nullptr) return;
  end = std::min(end, size_);
  // Only whole pages: the neighbours of a partial one may still be read. The file's last page
  // is whole as far as the mapping goes.
  const std::size_t page = g_page_size;
  const std::size_t first = (begin + page - 1) / page * page;
  const std::size_t last = end == size_ ? end : end / page * page;
  if (first >= last) return;
  // A failure leaves the pages resident: memory, not correctness, so nothing to report.
  [[maybe_unused]] const int rc =
      madvise(const_cast<std::byte*>(data_) + first, last - first, MADV_DONTNEED);
}

StatusOr<MappedFile> MappedFile::open(const std::filesystem::path& path) {
  struct stat st {};
  SSPC_ASSIGN_OR_RETURN(const int fd, open_regular_file(path, st));
  MappedFile file;
  file.path_ = path;
  file.size_ = static_cast<std::size_t>(st.st_size);
  file.fd_ = fd;
  if (file.size_ == 0) return file;
  install_sigbus_handler();
  void* p = mmap(nullptr, file.size_, PROT_READ, MAP_PRIVATE, fd, 0);
  if (p == MAP_FAILED) {
    const int err = errno;
    file.size_ = 0;
    return io_error(path.string() + ": cannot map: " + std::strerror(err));
  }
  file.data_ = static_cast<const std::byte*>(p);
  file.slot_ = register_mapping(file.data_, file.size_);
  if (file.slot_ < 0) {
    // Every slot is taken: an unguarded mapping could still kill the process, a copy cannot.
    munmap(p, file.size_);
    file.copy_ = std::make_unique_for_overwrite<std::byte[]>(file.size_);
    file.data_ = file.copy_.get();
    SSPC_RETURN_IF_ERROR(read_all(fd, path, file.copy_.get(), file.size_));
  }
  return file;
}

}  // namespace sspc
