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

}  // namespace celldem
