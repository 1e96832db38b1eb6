// libFuzzer target: sspc::read_xyz on arbitrary bytes (fuzz/reader_check.hpp says what must hold).
#include <cstddef>
#include <cstdint>

#include "reader_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto bytes = sspc::fuzz::as_bytes(data, size);
  const sspc::StatusOr<sspc::PointCloud> plain = sspc::read_xyz(bytes, "<fuzz>");
  sspc::fuzz::check_read_result(plain);
  sspc::fuzz::check_read_with_options(sspc::io::read_xyz_with_options, bytes, plain);
  return 0;
}
