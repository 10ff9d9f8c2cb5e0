#pragma once
// 3-vector arithmetic on std::array<T, 3>: Vec3 (float, rig/transform.hpp)
// and Vec3d (double: the geometry of bone heat and the bone-axis vote),
// written out component by component in one fixed order, so a result is
// bitwise the same wherever it is computed: the one copy the character
// pipeline uses.
#include <array>
#include <cmath>
#include <type_traits>

#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character {

using Vec3d = std::array<double, 3>;

template <class T>
inline std::array<T, 3> add(const std::array<T, 3>& a, const std::array<T, 3>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class T>
inline std::array<T, 3> sub(const std::array<T, 3>& a, const std::array<T, 3>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class T>
inline std::array<T, 3> scale(const std::array<T, 3>& a, std::type_identity_t<T> s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
template <class T>
inline T dot(const std::array<T, 3>& a, const std::array<T, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
inline std::array<T, 3> cross(const std::array<T, 3>& a, const std::array<T, 3>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class T>
inline T length(const std::array<T, 3>& a) {
  return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}
template <class T>
inline T distance(const std::array<T, 3>& a, const std::array<T, 3>& b) {
  return length(sub(a, b));
}
// a / |a| (as a times 1 / |a|); the zero vector stays zero.
template <class T>
inline std::array<T, 3> normalise(const std::array<T, 3>& a) {
  const T l = length(a);
  return l > T(0) ? scale(a, T(1) / l) : a;
}
inline Vec3d to_double(const Vec3& v) { return {v[0], v[1], v[2]}; }

}  // namespace gatcore::character
