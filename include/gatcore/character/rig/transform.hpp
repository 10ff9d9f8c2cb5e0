#pragma once
// Plain rigid-body math for characters: 3-vectors, unit quaternions, TRS
// transforms (the glTF node convention) and 4x4 column-major matrices (the
// glTF matrix convention). No Eigen in public headers.
#include <array>
#include <cmath>

namespace gatcore::character {

using Vec3 = std::array<float, 3>;
using Quat = std::array<float, 4>;   // x, y, z, w (glTF order), unit length
using Mat4 = std::array<float, 16>;  // column-major: m[col * 4 + row]

// Translation, rotation, scale: M = T * R * S.
struct Transform {
  Vec3 translation{0.0f, 0.0f, 0.0f};
  Quat rotation{0.0f, 0.0f, 0.0f, 1.0f};
  Vec3 scale{1.0f, 1.0f, 1.0f};
};

Mat4 mat4_identity();
Mat4 to_matrix(const Transform& t);
// Decomposes an affine matrix without shear into TRS (scale from column lengths).
Transform to_transform(const Mat4& m);
Mat4 mul(const Mat4& a, const Mat4& b);
Mat4 inverse(const Mat4& m);  // affine inverse; throws InvalidArgument if singular
Vec3 transform_point(const Mat4& m, const Vec3& p);
Vec3 mat4_translation(const Mat4& m);

Quat quat_mul(const Quat& a, const Quat& b);
Quat quat_normalize(const Quat& q);
Quat quat_from_axis_angle(const Vec3& axis, float radians);
Quat quat_slerp(const Quat& a, const Quat& b, float t);
Vec3 quat_rotate(const Quat& q, const Vec3& v);

}  // namespace gatcore::character
