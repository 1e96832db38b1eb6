// A read-only memory mapping of a whole file: how sspc reads point clouds and .sspc files.
//
// Mapping instead of reading lets the binary PLY reader run at memory speed and lets the
// decoder touch only the blocks a query needs. An empty file maps to an empty span.
#pragma once

#include <cstddef>
#include <filesystem>
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

 private:
  void reset();

  std::filesystem::path path_;
  const std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace sspc
