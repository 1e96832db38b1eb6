#include "core/atomic_file.hpp"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
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
  char path[kTempPathMax];
};
TempSlot g_temp_slots[kTempSlots];

int register_temporary(const std::filesystem::path& path) {
  const std::string& s = path.native();
  if (s.size() >= kTempPathMax) return -1;
  for (int i = 0; i < kTempSlots; ++i) {
    TempSlot& slot = g_temp_slots[i];
    bool expected = false;
    if (!slot.taken.compare_exchange_strong(expected, true)) continue;
    std::memcpy(slot.path, s.c_str(), s.size() + 1);
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

extern "C" void remove_temporaries_and_reraise(int sig) {
  for (TempSlot& slot : g_temp_slots) {
    if (slot.live.load(std::memory_order_acquire)) unlink(slot.path);
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
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  const int fd = mkstemp(name.data());
  if (fd < 0) {
    return io_error(target.string() + ": cannot create a temporary file in " + dir.string() +
                    ": " + errno_text());
  }
  temp_ = name.data();
  slot_ = register_temporary(temp_);
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
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) {
    const std::string why = errno_text();
    abandon();
    return io_error(target_.string() + ": close failed: " + why);
  }
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) {
    abandon();
    return io_error(target_.string() + ": cannot rename the temporary file: " + ec.message());
  }
  temp_.clear();
  unregister_temporary(slot_);
  slot_ = -1;
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

Status write_file_atomically(const std::filesystem::path& target, std::span<const std::byte> bytes) {
  AtomicFileWriter writer;
  SSPC_RETURN_IF_ERROR(writer.open(target));
  SSPC_RETURN_IF_ERROR(writer.write(bytes.data(), bytes.size()));
  return writer.commit();
}

}  // namespace sspc
