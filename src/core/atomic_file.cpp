#include "core/atomic_file.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace sspc {

namespace {
std::string errno_text() { return std::strerror(errno); }
}  // namespace

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
  file_ = fdopen(fd, "wb");
  if (file_ == nullptr) {
    close(fd);
    std::filesystem::remove(temp_);
    temp_.clear();
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
}

Status write_file_atomically(const std::filesystem::path& target, std::span<const std::byte> bytes) {
  AtomicFileWriter writer;
  SSPC_RETURN_IF_ERROR(writer.open(target));
  SSPC_RETURN_IF_ERROR(writer.write(bytes.data(), bytes.size()));
  return writer.commit();
}

}  // namespace sspc
