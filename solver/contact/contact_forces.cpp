#include "contact/contact_forces.hpp"

#include <algorithm>
#include <array>
#include <vector>

namespace celldem {
namespace {

// Reductions are summed over fixed blocks of owner particles (their pairs in list order), then the blocks
// in order. Only touching pairs add to them, so the result depends neither on the number of threads nor on
// which non-touching pairs the neighbour list happens to hold (so a rebuild never changes the arithmetic).
constexpr std::size_t kBlock = 256;

struct Partial {
  Mat3 stress_sum = Mat3::Zero();   // sum of force (x) branch [N m]
  Vec3 stiffness_sum = Vec3::Zero();  // sum of kn (n_k l_k)^2 [N m]
  std::int64_t touching = 0;
};

// Diagonal: the cell and the velocity gradient are diagonal (principal-axis loading, the common case); the
// products with h and L then skip their zero terms, which gives the same numbers bit for bit.
template <Kinematics K, bool Diagonal>
void pair_loop(const ContactParams& law, State& state, double dt) {
  const Particles& p = state.particles;
  PairList& pl = state.pairs;
  const Mat3 h = state.cell.h;
  const Mat3 L = state.cell.velocity_gradient;
  const std::size_t n = p.size();
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<Partial> partial(blocks);

#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < blocks; ++c) {
    Partial acc;
    const Index begin = pl.first[c * kBlock], end = pl.first[std::min(n, (c + 1) * kBlock)];
    for (Index q = begin; q < end; ++q) {
      const Index i = pl.owner[q], j = pl.neighbor[q];
      const auto& img = pl.image[q];
      const Vec3 ds = p.scaled[j] - p.scaled[i] + Vec3(img[0], img[1], img[2]);
      Vec3 branch;
      if constexpr (Diagonal) branch = h.diagonal().cwiseProduct(ds);
      else branch = h * ds;
      const double reach = p.radius[i] + p.radius[j];
      if (branch.squaredNorm() >= reach * reach) {  // most listed pairs: apart, nothing to compute
        if (pl.flags[q]) {  // a contact just opened: forget its history
          pl.flags[q] = 0;
          pl.tangential[q].setZero();
        }
        continue;
      }
      Vec3 dv = p.velocity[j] - p.velocity[i];
      if constexpr (K == Kinematics::Affine) {  // the images move apart with the cell
        if constexpr (Diagonal) dv += L.diagonal().cwiseProduct(branch);
        else dv += L * branch;
      }
      const ContactResult r = linear_spring_contact(law, branch, p.radius[i], p.radius[j], dv, p.spin[i],
                                                    p.spin[j], pl.tangential[q], dt);
      pl.force[q] = r.force;
      pl.torque_i[q] = r.torque_i;
      pl.torque_j[q] = r.torque_j;
      pl.tangential[q] = r.tangential;
      pl.flags[q] = static_cast<std::uint8_t>(kTouching | (r.sliding ? kSliding : 0));
      acc.stress_sum.noalias() += r.force * branch.transpose();
      acc.stiffness_sum += law.kn * (r.normal.array() * branch.array()).square().matrix();  // kn (n_k l_k)^2
      ++acc.touching;
    }
    partial[c] = acc;
  }

  Partial total;
  for (const Partial& part : partial) {
    total.stress_sum += part.stress_sum;
    total.stiffness_sum += part.stiffness_sum;
    total.touching += part.touching;
  }
  const double volume = state.cell.volume();
  state.stress = 0.5 * (total.stress_sum + total.stress_sum.transpose()) / volume;
  state.axis_stiffness = total.stiffness_sum / volume;
  state.touching = total.touching;
}

}  // namespace

void compute_contact_forces(const Model& model, double friction, State& state, bool advance_slip) {
  const double dt = advance_slip ? model.dt : 0.0;
  const ContactParams law{model.contact.kn, model.contact.kt, friction, model.contact.rotation,
                          model.contact.moment_arm};
  const auto off_diagonal = [](const Mat3& m) { return (m - Mat3(m.diagonal().asDiagonal())).cwiseAbs().maxCoeff(); };
  const bool diagonal = off_diagonal(state.cell.h) == 0.0 && off_diagonal(state.cell.velocity_gradient) == 0.0;
  if (model.kinematics == Kinematics::Affine) {
    if (diagonal) pair_loop<Kinematics::Affine, true>(law, state, dt);
    else pair_loop<Kinematics::Affine, false>(law, state, dt);
  } else {
    if (diagonal) pair_loop<Kinematics::Lammps, true>(law, state, dt);
    else pair_loop<Kinematics::Lammps, false>(law, state, dt);
  }
}

}  // namespace celldem
