#include "run/bench.hpp"

#include <omp.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "cell/control.hpp"
#include "core/plan.hpp"
#include "measure/series.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/thread_governor.hpp"
#include "step.hpp"

// The roofline (tools/roofline.py) runs the bench under callgrind with instrumentation off until the timed steps
// begin, so that the warm-up (which lets the neighbour list's skin adapt) runs at near-native speed and is not
// counted. Natively the client requests are a few no-op instructions; without valgrind's header, nothing.
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define CELLDEM_PROFILE_START() CALLGRIND_START_INSTRUMENTATION
#define CELLDEM_PROFILE_STOP() CALLGRIND_STOP_INSTRUMENTATION
#else
#define CELLDEM_PROFILE_START()
#define CELLDEM_PROFILE_STOP()
#endif

namespace celldem {

State tile_state(const State& s, int copies) {
  if (copies < 1) throw std::invalid_argument("tile_state: copies must be >= 1");
  // Factors of `copies` spread over the axes, largest first: 16 -> 4, 2, 2.
  int k[3] = {1, 1, 1};
  for (int left = copies, axis = 0; left > 1; axis = (axis + 1) % 3) {
    int f = 2;
    while (left % f != 0) ++f;
    k[axis] *= f;
    left /= f;
  }
  State t = s;
  const std::size_t n = s.particles.size();
  const std::vector<StoredContact> contacts = stored_contacts(s);
  t.particles.resize(0);
  t.particles.resize(n * copies);
  t.cell.h = s.cell.h * Vec3(k[0], k[1], k[2]).asDiagonal();
  std::vector<StoredContact> tiled;
  tiled.reserve(contacts.size() * copies);
  std::size_t copy = 0;
  for (int c = 0; c < k[2]; ++c)
    for (int b = 0; b < k[1]; ++b)
      for (int a = 0; a < k[0]; ++a, ++copy) {
        const Vec3 shift(a, b, c);
        for (std::size_t i = 0; i < n; ++i) {
          const std::size_t q = copy * n + i;
          t.particles.radius[q] = s.particles.radius[i];
          t.particles.scaled[q] = (s.particles.scaled[i] + shift).cwiseQuotient(Vec3(k[0], k[1], k[2]));
          t.particles.velocity[q] = s.particles.velocity[i];
          t.particles.spin[q] = s.particles.spin[i];
        }
        // A contact across the copy's boundary now joins a neighbouring copy; the history is kept only for
        // contacts inside the copy (those across are rebuilt from zero, a negligible warm-up difference).
        for (const StoredContact& cc : contacts)
          tiled.push_back({static_cast<Index>(copy * n + cc.i), static_cast<Index>(copy * n + cc.j),
                           cc.tangential, cc.flags, cc.rolling, cc.twist, cc.contact_radius});
      }
  begin_stage(t);
  set_stored_contacts(t, tiled);
  t.pairs.build_skin = s.pairs.build_skin;  // (set_stored_contacts leaves the list to be built)
  return t;
}

ShearTiming time_shear(const Deck& deck, const TestDef& test, const State& initial, int threads, std::int64_t steps,
                       std::int64_t warmup, bool governed, State* final_state) {
  omp_set_num_threads(threads);
  State state = initial;
  begin_stage(state);
  const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
  state.pairs.skin = skin_length(deck);
  const Loading loading{test.legs.front().axes, test.stage_friction()};
  evaluate_forces(model, test.stage_friction(), state);
  bool rebuild = false;
  std::int64_t done = 0;
  if (warmup > 0) advance_steps(model, loading, state, rebuild, [&](bool) { return ++done < warmup; }, threads);

  ShearTiming t;
  std::string sink;
  double row_seconds = 0.0;
  std::int64_t rows = 0;
  using Clock = std::chrono::steady_clock;
  ThreadGovernor governor(governed ? threads : 1);
  // As a run does: rows on one thread between steps, the region left when the governor changes the count.
  done = 0;
  const AfterStep after_step = [&](bool rebuilt) {
    t.rebuilds += rebuilt;
    const bool threads_changed = governor.step_done();
    if (++done % test.output_interval == 0) {
      const auto r0 = Clock::now();
      sink += format_series_row(measure_series_row(model, state));
      row_seconds += std::chrono::duration<double>(Clock::now() - r0).count();
      ++rows;
      if (sink.size() > (1u << 20)) sink.clear();
    }
    return done < steps && !threads_changed;
  };
  const auto start = Clock::now();
  CELLDEM_PROFILE_START();
  while (done < steps) advance_steps(model, loading, state, rebuild, after_step, governed ? governor.current() : threads);
  CELLDEM_PROFILE_STOP();
  t.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  t.particle_steps_per_second = static_cast<double>(state.particles.size()) * steps / t.seconds;
  t.row_seconds = rows ? row_seconds / rows : 0.0;
  t.step_seconds = (t.seconds - row_seconds) / steps;
  t.memory = memory_per_particle(state, model);
  t.bytes_per_particle = t.memory.total();
  t.pairs_per_particle = static_cast<double>(state.pairs.size()) / static_cast<double>(state.particles.size());
  t.crossings_per_particle =
      static_cast<double>(state.pairs.crossings()) / static_cast<double>(state.particles.size());
  t.contacts_per_particle = static_cast<double>(state.touching) / static_cast<double>(state.particles.size());
  if (final_state) *final_state = std::move(state);
  return t;
}

BusyProcess::BusyProcess() {
  pid_ = fork();
  if (pid_ == 0) {  // the child spins until it is killed
    volatile std::uint64_t x = 0;
    for (;;) x = x + 1;
  }
  if (pid_ < 0) throw std::runtime_error("bench: cannot start a busy process (fork failed)");
}

BusyProcess::~BusyProcess() {
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
}

std::vector<std::pair<std::string, Deck>> contact_law_variants(const Deck& deck) {
  if (deck.contact.normal != NormalModel::Linear || deck.contact.tangential != TangentialModel::LinearHistory ||
      deck.contact.rotational_history())
    throw DeckError("contact: the law comparison starts from a deck with the linear law");
  std::vector<std::pair<std::string, Deck>> out{{"linear", deck}};
  Deck d = deck;
  ContactDef& c = d.contact;
  // The mean contact force at the deck's largest stress, its linear overlap, and the modulus whose Hertz
  // tangent stiffness 2 E* sqrt(R* overlap) is kn there (R* of two mean spheres).
  const double d_mean = mean_diameter(d.sample);
  c.normal = NormalModel::Hertz;
  c.poisson_ratio = 0.25;
  const double overlap = mean_contact_force(deck.sample, largest_deck_stress(deck)) / deck.contact.kn;
  const double e_eff = deck.contact.kn / (2.0 * std::sqrt(0.25 * d_mean * overlap));
  c.youngs_modulus = e_eff * 2.0 * (1.0 - c.poisson_ratio * c.poisson_ratio);
  c.kn = 0.0;
  c.reference_overlap = default_reference_overlap(d);
  out.emplace_back("hertz", d);
  c.tangential = TangentialModel::Mindlin;
  c.kt = 0.0;
  out.emplace_back("hertz+mindlin", d);
  c.rolling = RollingModel::Sds;
  c.rolling_stiffness = deck.contact.kt > 0.0 ? deck.contact.kt : deck.contact.kn;
  c.rolling_friction = 0.1;
  for (TestDef& t : d.tests) t.rolling_friction = 0.1;
  out.emplace_back("hertz+mindlin+rolling", d);
  c.twisting = TwistingModel::Marshall;
  out.emplace_back("hertz+mindlin+rolling+twisting", d);
  return out;
}

MemoryPerParticle memory_per_particle(const State& s, const Model& m) {
  const Particles& p = s.particles;
  const PairList& pl = s.pairs;
  auto bytes = [](const auto& v) { return static_cast<double>(v.capacity() * sizeof(v[0])); };
  const double n = static_cast<double>(std::max<std::size_t>(p.size(), 1));
  MemoryPerParticle out;
  out.particles = (bytes(p.radius) + bytes(p.scaled) + bytes(p.velocity) + bytes(p.spin) + bytes(p.force) +
                   bytes(p.torque) + bytes(pl.first) + bytes(pl.incoming_first) + bytes(pl.incoming_crossing) +
                   bytes(pl.scaled_at_build)) / n;
  out.pairs = (bytes(pl.neighbor) + bytes(pl.image) + bytes(pl.tangential) + bytes(pl.rolling) + bytes(pl.twist) +
               bytes(pl.contact_radius) +
               bytes(pl.flags) + bytes(pl.force) + bytes(pl.torque_i) + bytes(pl.torque_j) + bytes(pl.incoming_pair)) / n;
  out.model = (bytes(m.velocity_keep) + bytes(m.velocity_gain) + bytes(m.spin_keep) +
               bytes(m.spin_gain)) / n;
  return out;
}

}  // namespace celldem
