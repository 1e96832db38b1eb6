// A read-only memory mapping of a whole file: how sspc reads point clouds and .sspc files.
//
// Mapping instead of reading lets the binary PLY reader run at memory speed and lets the
// decoder touch only the blocks a query needs. An empty file maps to an empty span.
//
// A file can shrink while it is mapped (another program truncates it or rewrites it in place).
// Touching a page that then lies wholly past the end of the file raises SIGBUS, whose default
// action ends the process without a word. So every live mapping is registered, as (start,
// length), in a fixed table of lock-free atomics, and a SIGBUS handler installed once per
// process looks the fault address up there:
//   - inside a registered mapping, it marks that mapping truncated and maps a page of zeros
//     over the faulting page (MAP_FIXED); the faulting read is retried and continues on zeros;
//   - anywhere else (or for a SIGBUS sent with kill), it hands the signal to the disposition
//     that was installed before it: that handler, or the default action.
// The page that holds the file's new end raises no signal (the kernel zero-fills the rest of
// it), so truncated() also compares the file's current size with the mapped size. Callers parse
// what they read and then ask check_intact(); its error replaces whatever the parser made of the
// zeros. The handler reads only the table and calls mmap (a system call, safe in a signal
// handler on Linux although POSIX does not list it). When every slot of the table is taken,
// open() reads the file into memory instead of mapping it, so no mapping is ever unguarded.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>

#include "sspc/status.hpp"

namespace sspc {

class MappedFile {
 public:
  MappedFile() = default;
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&& other) noexcept;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile();

  // Fails with kNotFound, kIoError, or kInvalidArgument for anything but a regular file
  // ("x.ply: not a regular file (a FIFO)"; also a socket, a character or block device, a
  // directory). Never blocks: a FIFO is refused without waiting for a writer.
  static StatusOr<MappedFile> open(const std::filesystem::path& path);

  std::span<const std::byte> bytes() const { return {data_, size_}; }
  std::size_t size() const { return size_; }
  const std::filesystem::path& path() const { return path_; }

  // True once the file has shrunk below the mapped size: a read past the new end was served
  // zeros, or the file is now shorter than it was when mapped. Thread-safe.
  bool truncated() const;
  // kIoError "PATH: the file shrank while it was read (was N bytes)" when truncated().
  Status check_intact() const;

  // Hands the pages wholly inside bytes [begin, end) back to the kernel, so that a reader
  // streaming through a file larger than memory holds only the part it is at: the file's pages
  // count toward the process's resident memory for as long as they stay mapped in. A page touched
  // again is read from the file again. Does nothing to the in-memory copy made when the fault
  // table was full.
  void release(std::size_t begin, std::size_t end) const;

 private:
  void reset();

  std::filesystem::path path_;
  const std::byte* data_ = nullptr;
  std::size_t size_ = 0;
  int slot_ = -1;                      // the mapping's entry in the fault handler's table
  int fd_ = -1;                        // kept open to compare the file's size with the mapped size
  std::unique_ptr<std::byte[]> copy_;  // the file's bytes when the table was full
};

}  // namespace sspc
