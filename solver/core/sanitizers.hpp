#pragma once
// CELLDEM_SANITIZED: defined where AddressSanitizer is compiled in. GCC says so with a macro, clang (which the
// sanitizer build uses where it is installed, tools/test.sh) with __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define CELLDEM_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CELLDEM_SANITIZED 1
#endif
#endif
