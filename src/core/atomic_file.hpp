// Writes a file so that readers see either the old file or the complete new one, never half.
//
// The data goes to a temporary file beside the target (same directory, so the rename stays on
// one file system), is flushed, and is renamed over the target by commit(). If commit() is not
// reached (an error, an exception, a crash) the temporary file is removed and the target is
// untouched.
#pragma once

#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "sspc/status.hpp"

namespace sspc {

class AtomicFileWriter {
 public:
  AtomicFileWriter() = default;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  Status open(const std::filesystem::path& target);
  Status write(const void* data, std::size_t size);
  Status write(std::string_view text) { return write(text.data(), text.size()); }
  // Flushes, syncs and renames the temporary file over the target.
  Status commit();
  // Removes the temporary file; the target is left as it was.
  void abandon();

  const std::filesystem::path& target() const { return target_; }

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  std::FILE* file_ = nullptr;
};

// Convenience: the whole of `bytes` written atomically to `target`.
Status write_file_atomically(const std::filesystem::path& target, std::span<const std::byte> bytes);

}  // namespace sspc
