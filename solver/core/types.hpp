// Small fixed-size linear algebra used everywhere. Eigen's fixed types compile to plain arithmetic.
#pragma once
#include <Eigen/Dense>
#include <cstdint>

namespace celldem {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;  // the six components in Voigt order (core/choices.hpp)
using Vec3f = Eigen::Vector3f;  // 12 bytes: for what needs no double precision
using Mat3 = Eigen::Matrix3d;
using Index = std::int32_t;  // particle and contact indices (ids, not pointers)

// The SIMD kernels (the pair loop's outputs, the drift, the kick, the largest move) read arrays of 3-vectors as
// plain arrays of 3 n numbers.
static_assert(sizeof(Vec3) == 3 * sizeof(double) && sizeof(Vec3f) == 3 * sizeof(float), "3-vectors are packed");

}  // namespace celldem
