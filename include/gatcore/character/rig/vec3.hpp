#pragma once
// 3-vector arithmetic on Vec3 (rig/transform.hpp), in float, written out
// component by component: the one copy the character pipeline uses.
#include <cmath>

#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character {

inline Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3 scale(const Vec3& a, float s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline float length(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
inline float distance(const Vec3& a, const Vec3& b) { return length(sub(a, b)); }
// a / |a|; the zero vector stays zero.
inline Vec3 normalise(const Vec3& a) {
  const float l = length(a);
  return l > 0.0f ? scale(a, 1.0f / l) : a;
}

}  // namespace gatcore::character
