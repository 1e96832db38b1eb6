// libFuzzer target: sspc::read_las on arbitrary bytes. An error has a message; a success is a
// valid, non-empty cloud that the LAS writer writes and the reader reads back to the same number
// of points, each at the same place in the world when the reader said nothing of float32's
// bound (io/las_reader.cpp); reading with warnings and positions in double accepts and refuses
// the same bytes and gives the same cloud.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "io/reader_common.hpp"
#include "sspc/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sspc;
  const auto bytes = fuzz::as_bytes(data, size);
  std::vector<std::string> warnings;
  std::vector<Vec3d> wide;
  ReadOptions options;
  options.warnings = &warnings;
  options.positions_f64 = &wide;
  const StatusOr<PointCloud> plain = read_las(bytes, "<fuzz>");
  const StatusOr<PointCloud> full = io::read_las_with_options(bytes, "<fuzz>", options);
  SSPC_FUZZ_CHECK(plain.ok() == full.ok());
  if (!plain.ok()) {
    SSPC_FUZZ_CHECK(!plain.status().message().empty());
    return 0;
  }
  const PointCloud& cloud = *plain;
  SSPC_FUZZ_CHECK_CLOUD(cloud);
  SSPC_FUZZ_CHECK(full->positions.size() == cloud.size());
  SSPC_FUZZ_CHECK(std::memcmp(full->positions.data(), cloud.positions.data(),
                              cloud.size() * sizeof(Vec3f)) == 0);
  SSPC_FUZZ_CHECK(wide.size() == cloud.size());

  const StatusOr<std::string> written = encode_las(cloud);
  if (!written.ok()) {
    SSPC_FUZZ_CHECK(written.status().code() == StatusCode::kInvalidArgument);
    return 0;
  }
  const StatusOr<PointCloud> again =
      read_las(std::as_bytes(std::span<const char>(written->data(), written->size())), "<again>");
  SSPC_FUZZ_CHECK(again.ok());
  SSPC_FUZZ_CHECK(again->size() == cloud.size());
  bool exact = true;
  for (const std::string& w : warnings) {
    exact = exact && w.find("not bit for bit") == std::string::npos;
  }
  if (exact) {
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Vec3d a = again->world(i), b = cloud.world(i);
      const Vec3d step = cloud.metadata.las->scale.cwiseAbs();
      // The same grid point: float32 local values hold it within a quarter step each time.
      SSPC_FUZZ_CHECK(
          ((a - b).cwiseAbs().array() <= step.array() * 0.5 + 1e-9 * b.cwiseAbs().array()).all());
    }
  }
  return 0;
}
