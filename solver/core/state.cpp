#include "core/state.hpp"

namespace celldem {

void Particles::resize(std::size_t n) {
  radius.resize(n);
  scaled.resize(n, Vec3::Zero());
  velocity.resize(n, Vec3::Zero());
  spin.resize(n, Vec3::Zero());
  force.resize(n, Vec3::Zero());
  torque.resize(n, Vec3::Zero());
}

}  // namespace celldem
