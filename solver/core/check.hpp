// Invariants the hot code relies on, checked in the checking build (CMake -DCELLDEM_CHECKS=ON, which the test
// suite's sanitizer build uses) and compiled out otherwise, so the release build's arithmetic and speed are
// untouched. A broken invariant is a bug in celldem, never bad input (that is a DeckError naming the key): the
// check prints the condition, what it means and where, and aborts.
#pragma once
#include <cstdio>
#include <cstdlib>

namespace celldem::detail {
[[noreturn]] inline void invariant_failed(const char* condition, const char* what, const char* file, int line) {
  std::fprintf(stderr, "celldem: invariant broken at %s:%d: %s (%s)\n", file, line, what, condition);
  std::abort();
}
}  // namespace celldem::detail

#ifdef CELLDEM_CHECKS
inline constexpr bool kCheckInvariants = true;
#define CELLDEM_ASSERT(condition, what) \
  ((condition) ? static_cast<void>(0) : ::celldem::detail::invariant_failed(#condition, what, __FILE__, __LINE__))
#else
inline constexpr bool kCheckInvariants = false;
#define CELLDEM_ASSERT(condition, what) static_cast<void>(0)
#endif
