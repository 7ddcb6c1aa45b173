// Shared helpers for the unit and physics tests: small models, states and temporary folders.
// Nothing here computes a physical answer: the expected values live in the tests, derived by hand.
#pragma once
#include <optional>
#include <omp.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cell/control.hpp"
#include "contact/contact_forces.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "integrate/leapfrog.hpp"
#include "io/deck_reader.hpp"
#include "neighbor/neighbor_list.hpp"
#include "stepping.hpp"

namespace celldem::testing {

// Three draws of dist as a vector, z drawn first. A constructor's arguments are evaluated in an order each
// compiler picks (GCC right to left, clang left to right), so Vec3(u(gen), u(gen), u(gen)) made
// another scene under each; z first keeps the scenes the tests were written with under GCC.
template <class Dist, class Gen>
Vec3 draw_vec3(Dist& dist, Gen& gen) {
  const double z = dist(gen);
  const double y = dist(gen);
  const double x = dist(gen);
  return Vec3(x, y, z);
}

// The shear axes x12, x13, x23 of a loading's or leg's six components: as given, or held where none is given.
inline void set_shear(std::array<AxisControl, kComponents>& axes, const std::array<std::optional<AxisControl>, 3>& shear) {
  for (int a = 0; a < 3; ++a) axes[3 + a] = shear[a] ? *shear[a] : AxisControl{AxisMode::Held};
}

// Density that gives a sphere of diameter 1 m a mass of 1 kg.
inline constexpr double kUnitMassDensity = 6.0 / M_PI;

// A deck holding only what make_model reads (the sample block is a placeholder).
inline Deck model_deck(double kn, double kt, double dt, double density = kUnitMassDensity,
                       double damping_translational = 0.0, double damping_rotational = 0.0) {
  Deck d;
  d.sample.count = 1;
  d.sample.diameters = {1.0};
  d.sample.density = density;
  d.sample.grid_spacing = 1.1;
  d.contact.kn = kn;
  d.contact.kt = kt;
  d.damping.translational = damping_translational;
  d.damping.rotational = damping_rotational;
  d.time_step = dt;
  d.prepare = PrepareDef{};
  return d;
}

// A state in the cell h with particles at the given real positions (scaled = h^-1 x), at rest.
inline State make_state(const Mat3& h, const std::vector<double>& radius, const std::vector<Vec3>& position,
                        double skin) {
  State s;
  s.cell.h = h;
  s.particles.resize(radius.size());
  const Mat3 hinv = h.inverse();
  for (std::size_t i = 0; i < radius.size(); ++i) {
    s.particles.radius[i] = radius[i];
    s.particles.scaled[i] = hinv * position[i];
  }
  s.pairs.skin = skin;
  s.control.reference.head<3>() = h.diagonal();
  s.control.reference_volume = h.determinant();
  return s;
}

// Simple (rectangular) lattice of n x n x n equal spheres, spacings a[k], one sphere per lattice cell.
inline State lattice_state(int n, double radius, const Vec3& spacing, double skin) {
  const Mat3 h = (spacing * n).asDiagonal();
  std::vector<double> r;
  std::vector<Vec3> x;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        r.push_back(radius);
        x.push_back(Vec3((i + 0.5) * spacing[0], (j + 0.5) * spacing[1], (k + 0.5) * spacing[2]));
      }
  return make_state(h, r, x, skin);
}

// A face-centred cubic lattice of n^3 cubic cells (4 n^3 equal spheres of radius `radius`), lattice constant
// a: each sphere touches its 12 nearest neighbours at distance a / sqrt(2) when 2 radius exceeds it.
inline State fcc_state(int n, double radius, double a, double skin) {
  const Mat3 h = Mat3::Identity() * (a * n);
  const Vec3 basis[4] = {Vec3(0.25, 0.25, 0.25), Vec3(0.75, 0.75, 0.25), Vec3(0.75, 0.25, 0.75), Vec3(0.25, 0.75, 0.75)};
  std::vector<double> r;
  std::vector<Vec3> x;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const Vec3& b : basis) {
          r.push_back(radius);
          x.push_back(a * (Vec3(i, j, k) + b));
        }
  return make_state(h, r, x, skin);
}

// The state after three force evaluations and a kick from `base`, once per thread count: for comparing bits.
inline std::vector<State> on_thread_counts(const Model& model, const State& base, const Friction& friction,
                                           std::initializer_list<int> thread_counts) {
  const int saved = omp_get_max_threads();
  std::vector<State> results;
  for (int threads : thread_counts) {
    omp_set_num_threads(threads);
    State s = base;
    rebuild_pairs(model, s);
    for (int k = 0; k < 3; ++k) compute_contact_forces(model, friction, s);
    gather_and_kick(model, s);
    results.push_back(std::move(s));
  }
  omp_set_num_threads(saved);
  return results;
}

// A 0.98-spaced lattice of n^3 unit spheres, each moved by up to `jitter` (scaled), with random velocities
// up to `speed` and spins up to `spin` per component: many contacts, some sliding, all different.
inline State jostled_lattice(int n, std::uint64_t seed, double jitter, double speed, double spin) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s = lattice_state(n, 0.5, Vec3(0.98, 0.98, 0.98), 0.1);
  const Mat3 hinv = s.cell.h.inverse();
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    s.particles.scaled[i] += hinv * draw_vec3(u, gen) * jitter;
    s.particles.velocity[i] = draw_vec3(u, gen) * speed;
    s.particles.spin[i] = draw_vec3(u, gen) * spin;
  }
  return s;
}

inline Loading fixed_cell(double friction = 0.0) {
  const AxisControl a{AxisMode::StrainIncrement, 0.0};
  return Loading{{a, a, a}, friction};
}

// Index of the pair (i, j) in the list, or -1.
inline int find_pair(const PairList& pl, Index i, Index j) {
  if (i < 0 || static_cast<std::size_t>(i) + 1 >= pl.first.size()) return -1;
  for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q)
    if (pl.neighbor[q] == j) return q;
  return -1;
}

// A fresh folder under the system temporary directory, removed with everything in it at the end of scope.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "celldem-test-XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

inline std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_bytes(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

// A small preparation deck: ~300 polydisperse spheres, loose equilibrium tolerances, so that a packing at
// 100 kPa is made in well under a second on one thread. `tests` is the JSON text of the "tests" array.
inline std::string small_deck_json(int count, const std::string& tests, std::uint64_t seed = 3) {
  return R"({
  "format": 1,
  "description": "tiny test deck",
  "sample": {"count": )" + std::to_string(count) + R"(, "diameters": {"min": 3.0e-3, "max": 4.5e-3, "count": 4},
             "density": 2650, "seed": )" + std::to_string(seed) + R"(, "grid_spacing": 5.0e-3},
  "contact": {"kn": 1.0e6, "kt": 1.0e6},
  "damping": {"translational": 0.1, "rotational": 0.1},
  "time_step": 3.0e-6,
  "servo": {"max_strain_increment": 4e-5},
  "prepare": {"target_pressure": 1.0e5, "fast_strain_increment": 1e-4, "fast_solid_fraction": 0.55,
              "output_interval": 500,
              "equilibrium": {"pressure_tolerance": 0.01, "stress_tolerance": 0.02, "unbalanced_force_ratio": 0.02,
                              "min_steps": 1000, "check_interval": 500, "max_steps": 200000}},
  "tests": )" + tests + "\n}\n";
}

}  // namespace celldem::testing
