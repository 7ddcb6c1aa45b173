#include "contact/contact_forces_reference.hpp"

#include <stdexcept>

#include "contact/contact_law.hpp"

namespace celldem {
namespace {

template <class Law>
void evaluate_pairs(const ContactParams& params, Kinematics kinematics, const State& state, double dt,
                    ReferenceContactForces& out) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const Mat3& h = state.cell.h;
  const Mat3& L = state.cell.velocity_gradient;
  Vec3 normal_sum = Vec3::Zero(), stiffness_sum = Vec3::Zero(), shear_sum = Vec3::Zero(), shear_stiffness_sum = Vec3::Zero();
  for_each_pair(pl, [&](Index i, Index q) {
    const Index j = pl.neighbor[q];
    const Vec3 branch = h * (p.scaled[j] - p.scaled[i] + Vec3(pl.image[q][0], pl.image[q][1], pl.image[q][2]));
    Vec3 dv = p.velocity[j] - p.velocity[i];
    if (kinematics == Kinematics::Affine) dv = dv + L * branch;  // the images move apart with the cell
    ContactHistory before;
    before.tangential = real3(pl.tangential[q]);
    if constexpr (Law::rotational) before.rolling = real3(pl.rolling[q]), before.twist = pl.twist[q];
    if constexpr (Law::radius_history) before.contact_radius = pl.contact_radius[q];
    const PairContact c = contact_law<Law>(params, real3(branch), p.radius[i], p.radius[j], real3(dv),
                                           real3(p.spin[i]), real3(p.spin[j]), before, dt);

    out.force[q] = vec3(c.force);
    out.tangential[q] = vec3(c.history.tangential);
    if constexpr (Law::rotational) out.rolling[q] = vec3(c.history.rolling), out.twist[q] = c.history.twist;
    if constexpr (Law::radius_history) out.contact_radius[q] = c.history.contact_radius;
    out.flags[q] = static_cast<std::uint8_t>((c.touching ? kTouching : 0) | (c.sliding ? kSliding : 0));

    out.net_force[i] -= vec3(c.force);
    out.net_force[j] += vec3(c.force);
    out.net_torque[i] += vec3(c.torque_i);
    out.net_torque[j] += vec3(c.torque_j);

    const Vec3 nl = vec3(c.normal).cwiseProduct(branch);  // n_k l_k, component by component
    normal_sum += vec3(c.force).cwiseProduct(branch);
    stiffness_sum += c.normal_stiffness * nl.cwiseProduct(nl);
    const Vec3 f = vec3(c.force), n = vec3(c.normal);
    shear_sum += 0.5 * Vec3(f[0] * branch[1] + f[1] * branch[0], f[0] * branch[2] + f[2] * branch[0],
                            f[1] * branch[2] + f[2] * branch[1]);
    const Vec3 nt(n[0] * branch[1], n[0] * branch[2], n[1] * branch[2]);  // n_i l_j, ij = 12, 13, 23
    shear_stiffness_sum += c.normal_stiffness * nt.cwiseProduct(nt);
    out.touching += c.touching;
  });
  const double volume = state.cell.volume();
  out.stress << normal_sum / volume, shear_sum / volume;
  out.stiffness << stiffness_sum / volume, shear_stiffness_sum / volume;
}

}  // namespace

ReferenceContactForces reference_contact_forces(const Model& model, const Friction& friction, const State& state,
                                                bool advance_slip) {
  const PairList& pl = state.pairs;
  const std::size_t n = state.particles.size(), pairs = pl.size();
  if (pl.first.size() != n + 1) throw std::logic_error("reference_contact_forces: the pair list is not built");
  if (model.contact.rotational_history() && pl.rolling.size() != pairs)
    throw std::logic_error("reference_contact_forces: the pair list has no rotational springs (rebuild it first)");
  if (model.contact.radius_history() && pl.contact_radius.size() != pairs)
    throw std::logic_error("reference_contact_forces: the pair list has no contact radii (rebuild it first)");
  ReferenceContactForces out;
  out.force.assign(pairs, Vec3::Zero());
  out.tangential.assign(pairs, Vec3::Zero());
  out.rolling.assign(pl.rolling.size(), Vec3::Zero());
  out.twist.assign(pl.twist.size(), 0.0);
  out.contact_radius.assign(pl.contact_radius.size(), 0.0);
  out.flags.assign(pairs, 0);
  out.net_force.assign(n, Vec3::Zero());
  out.net_torque.assign(n, Vec3::Zero());
  const ContactParams params = contact_params(model.contact, friction);
  const double dt = advance_slip ? model.dt : 0.0;
  with_law(model.contact, [&](auto law) { evaluate_pairs<decltype(law)>(params, model.kinematics, state, dt, out); });
  return out;
}

}  // namespace celldem
