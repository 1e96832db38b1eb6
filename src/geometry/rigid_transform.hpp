// A rigid transform x ↦ R x + t, R a rotation. Named by its frames at the point of use
// (`world_from_patch`, `patch_from_codeword`), as pbrt does, so that an inverse is never applied
// by mistake: `a_from_c = a_from_b * b_from_c`.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace sspc {

struct RigidTransform {
  Eigen::Matrix3f rotation = Eigen::Matrix3f::Identity();
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();

  static RigidTransform identity() { return {}; }

  Eigen::Vector3f apply(const Eigen::Vector3f& p) const { return rotation * p + translation; }
  Eigen::Vector3f apply_vector(const Eigen::Vector3f& v) const { return rotation * v; }

  RigidTransform inverse() const {
    RigidTransform inv;
    inv.rotation = rotation.transpose();
    inv.translation = -(inv.rotation * translation);
    return inv;
  }

  // (this ∘ other)(x) = this(other(x)).
  RigidTransform operator*(const RigidTransform& other) const {
    RigidTransform out;
    out.rotation = rotation * other.rotation;
    out.translation = rotation * other.translation + translation;
    return out;
  }
};

// True when `r` is orthonormal with determinant +1 to within `tolerance`.
inline bool is_rotation(const Eigen::Matrix3f& r, float tolerance = 1e-4f) {
  const float orthogonality = (r.transpose() * r - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff();
  return orthogonality <= tolerance && std::abs(r.determinant() - 1.0f) <= tolerance;
}

}  // namespace sspc
