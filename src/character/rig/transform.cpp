#include "gatcore/character/rig/transform.hpp"

#include <Eigen/Dense>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {
using M4 = Eigen::Matrix4f;
M4 to_eigen(const Mat4& m) { return Eigen::Map<const M4>(m.data()); }
Mat4 from_eigen(const M4& e) {
  Mat4 m;
  Eigen::Map<M4>(m.data()) = e;
  return m;
}
}  // namespace

Mat4 mat4_identity() { return from_eigen(M4::Identity()); }

Mat4 to_matrix(const Transform& t) {
  const Quat q = quat_normalize(t.rotation);
  Eigen::Quaternionf eq(q[3], q[0], q[1], q[2]);
  M4 m = M4::Identity();
  m.topLeftCorner<3, 3>() = eq.toRotationMatrix() * Eigen::Vector3f(t.scale[0], t.scale[1], t.scale[2]).asDiagonal();
  m.topRightCorner<3, 1>() = Eigen::Vector3f(t.translation[0], t.translation[1], t.translation[2]);
  return from_eigen(m);
}

Transform to_transform(const Mat4& mm) {
  const M4 m = to_eigen(mm);
  Transform t;
  Eigen::Matrix3f a = m.topLeftCorner<3, 3>();
  for (int c = 0; c < 3; ++c) {
    float s = a.col(c).norm();
    if (s <= 0.0f) s = 1.0f;
    t.scale[c] = s;
    a.col(c) /= s;
  }
  if (a.determinant() < 0.0f) {  // a mirror: put it in the x scale
    t.scale[0] = -t.scale[0];
    a.col(0) = -a.col(0);
  }
  Eigen::Quaternionf q(a);
  q.normalize();
  t.rotation = {q.x(), q.y(), q.z(), q.w()};
  t.translation = {m(0, 3), m(1, 3), m(2, 3)};
  return t;
}

Mat4 mul(const Mat4& a, const Mat4& b) { return from_eigen(to_eigen(a) * to_eigen(b)); }

Mat4 inverse(const Mat4& mm) {
  const Eigen::Matrix4d m = to_eigen(mm).cast<double>();
  const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
  const double det = a.determinant();
  GATCORE_CHECK(std::isfinite(det) && std::abs(det) > 1e-30, "inverse: singular transform (det ", det, ")");
  Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
  r.topLeftCorner<3, 3>() = a.inverse();
  r.topRightCorner<3, 1>() = -r.topLeftCorner<3, 3>() * m.topRightCorner<3, 1>();
  return from_eigen(r.cast<float>());
}

Vec3 transform_point(const Mat4& m, const Vec3& p) {
  return {m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12], m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13],
          m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14]};
}

Vec3 mat4_translation(const Mat4& m) { return {m[12], m[13], m[14]}; }

Quat quat_mul(const Quat& a, const Quat& b) {
  return {a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1], a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
          a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3], a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
}

Quat quat_normalize(const Quat& q) {
  const float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0.0f)) return {0.0f, 0.0f, 0.0f, 1.0f};
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

Quat quat_from_axis_angle(const Vec3& axis, float radians) {
  const float n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  if (!(n > 0.0f)) return {0.0f, 0.0f, 0.0f, 1.0f};
  const float s = std::sin(0.5f * radians) / n;
  return {axis[0] * s, axis[1] * s, axis[2] * s, std::cos(0.5f * radians)};
}

Quat quat_slerp(const Quat& a, const Quat& b0, float t) {
  Eigen::Quaternionf qa(a[3], a[0], a[1], a[2]), qb(b0[3], b0[0], b0[1], b0[2]);
  const Eigen::Quaternionf q = qa.normalized().slerp(t, qb.normalized());
  return {q.x(), q.y(), q.z(), q.w()};
}

Vec3 quat_rotate(const Quat& q, const Vec3& v) {
  const Eigen::Quaternionf e(q[3], q[0], q[1], q[2]);
  const Eigen::Vector3f r = e.normalized() * Eigen::Vector3f(v[0], v[1], v[2]);
  return {r.x(), r.y(), r.z()};
}

}  // namespace gatcore::character
