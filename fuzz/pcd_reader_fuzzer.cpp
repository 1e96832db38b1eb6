// libFuzzer target: sspc::read_pcd on arbitrary bytes (fuzz/reader_check.hpp says what must hold).
#include <cstddef>
#include <cstdint>

#include "reader_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  sspc::fuzz::check_read_result(sspc::read_pcd(sspc::fuzz::as_bytes(data, size), "<fuzz>"));
  return 0;
}
