// A downstream program: generates a sphere, writes and reads it back through the installed API.
#include <sspc/io.hpp>
#include <sspc/synthetic.hpp>

#include <cstdio>

int main() {
  const sspc::PointCloud sphere = sspc::synthetic::sphere(1000, 1.0);
  const std::string bytes = sspc::encode_ply(sphere);
  auto back = sspc::read_ply(std::as_bytes(std::span(bytes.data(), bytes.size())), "memory");
  if (!back.ok()) {
    std::fprintf(stderr, "%s\n", back.status().to_string().c_str());
    return 1;
  }
  std::printf("points=%zu\n", back->size());
  return back->size() == 1000 ? 0 : 1;
}
