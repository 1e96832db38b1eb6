#include "encoder/codeword_surface.hpp"

namespace sspc::codec {

CodewordSurface::CodewordSurface(std::span<const Vec3f> points, std::span<const Vec3f> normals)
    : points_(points), normals_(normals), tree_(points) {}

}  // namespace sspc::codec
