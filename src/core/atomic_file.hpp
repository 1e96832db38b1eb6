// Writes a file so that readers see either the old file or the complete new one, never half.
//
// The data goes to a temporary file beside the target (same directory, so the rename stays on
// one file system), is flushed, and is renamed over the target by commit(). If commit() is not
// reached (an error, an exception, a crash) the temporary file is removed and the target is
// untouched. A process killed by a signal runs no destructors; a program that calls
// remove_temporary_files_on_signals() (the sspc CLI does) has its temporary files removed on
// SIGINT, SIGTERM and SIGHUP too, and sees an exceeded file-size limit (SIGXFSZ) as a failed
// write instead of dying of it.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

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
  // Overwrites bytes already written at `offset` (a header filled in at the end); the next
  // write() still appends.
  Status write_at(std::uint64_t offset, std::string_view bytes);
  // Flushes what was written to the temporary file, so that a reader of temporary_path() sees it.
  Status flush();
  const std::filesystem::path& temporary_path() const { return temp_; }
  // Flushes, syncs and renames the temporary file over the target.
  Status commit();
  // Removes the temporary file; the target is left as it was.
  void abandon();

  const std::filesystem::path& target() const { return target_; }

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  std::FILE* file_ = nullptr;
  int slot_ = -1;  // in the table of temporary files a signal handler removes
};

// A scratch file (`prefix`, six random characters, `extension`, in `dir`) that its destructor and
// the signal handlers of remove_temporary_files_on_signals() remove: what a command writes before
// it copies it to stdout.
class TemporaryFile {
 public:
  static StatusOr<TemporaryFile> create(const std::filesystem::path& dir, const std::string& prefix,
                                        const std::string& extension);
  TemporaryFile(TemporaryFile&& other) noexcept;
  TemporaryFile& operator=(TemporaryFile&&) = delete;
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  ~TemporaryFile();
  const std::filesystem::path& path() const { return path_; }

 private:
  TemporaryFile() = default;
  std::filesystem::path path_;
  int slot_ = -1;
};

// Several files that appear together or not at all (a rendered sequence and its times): each is
// written complete into a hidden folder beside the targets, and commit() renames them into
// place one by one. Until then nothing outside the folder changes; abandon(), the destructor,
// and the signal handlers of remove_temporary_files_on_signals() remove the folder and what it
// holds.
class StagingDirectory {
 public:
  StagingDirectory() = default;
  StagingDirectory(const StagingDirectory&) = delete;
  StagingDirectory& operator=(const StagingDirectory&) = delete;
  ~StagingDirectory();

  // Creates the folder in `dir` (where the targets are).
  Status open(const std::filesystem::path& dir);
  // Where to write the file that commit() moves to `target` (in the folder given to open()).
  std::filesystem::path stage(const std::filesystem::path& target);
  // Renames every staged file that was written to its target, then removes the folder.
  Status commit();
  void abandon();

  // The file in the folder whose lock its owner holds (remove_stale_temporaries).
  static constexpr const char* kOwnerName = ".owner";

 private:
  std::filesystem::path dir_;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> staged_;  // (staged, target)
  int slot_ = -1;
  int lock_fd_ = -1;
};

// What a run left in `dir` when it was killed beyond a handler's reach (SIGKILL: the OOM
// killer's signal): AtomicFileWriter temporaries and StagingDirectory folders (a memory-limited
// encode's staged tiles, about 1.8 times its input). Each holds a lock while its process lives,
// so one whose lock is free, and that is at least `min_age` old (not being made this moment), is
// removed. A staging folder without the owner's file (made by an sspc before the locks) is only
// named, for the caller to report.
struct StaleTemporaries {
  std::vector<std::filesystem::path> removed;
  std::vector<std::filesystem::path> unknown;
};
StaleTemporaries remove_stale_temporaries(const std::filesystem::path& dir,
                                          std::chrono::seconds min_age = std::chrono::seconds(60));

// Installs handlers for SIGINT, SIGTERM and SIGHUP that remove the open writers' temporary files
// and then end the process as the signal would have; ignores SIGXFSZ, so that writing past a
// file-size limit fails with EFBIG (and the writer cleans up) instead of killing the process.
void remove_temporary_files_on_signals();

// Convenience: the whole of `bytes` written atomically to `target`.
Status write_file_atomically(const std::filesystem::path& target, std::span<const std::byte> bytes);

}  // namespace sspc
