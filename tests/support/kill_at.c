/* A fault injector for the test harnesses, loaded with LD_PRELOAD: counts the process's file events (a file opened
 * for writing or created, a rename, an unlink, a folder made or removed) and raises SIGKILL at the N-th, before the
 * event happens. Environment:
 *   CELLDEM_KILL_AT=N    the event to die at (1 = the first); unset or 0: never, only count and list
 *   CELLDEM_KILL_LOG=F   appends a line per event to F: "N EVENT PATH" (the N-th event, at which a kill would
 *                        land; the last line of a killed process's log is the event it died at, marked "KILL")
 * Events of any thread count, in the order they happen. Generic: a harness may kill any celldem command (a merge,
 * a run) at any of its file events. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

static atomic_long events;

/* Counts one event; lists it; dies when it is the one asked for. */
static void event(const char* what, const char* path) {
  const long n = atomic_fetch_add(&events, 1) + 1;
  const char* at = getenv("CELLDEM_KILL_AT");
  const long kill_at = at ? atol(at) : 0;
  const char* log = getenv("CELLDEM_KILL_LOG");
  if (log && *log) {
    /* The raw system call: no interposed function, no stdio buffer lost to the kill. */
    const int fd = (int)syscall(SYS_openat, AT_FDCWD, log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) {
      char line[4200];
      const int len = snprintf(line, sizeof line, "%ld %s %s%s\n", n, what, path ? path : "?",
                               n == kill_at ? " KILL" : "");
      if (len > 0) (void)!write(fd, line, (size_t)(len < (int)sizeof line ? len : (int)sizeof line - 1));
      close(fd);
    }
  }
  if (kill_at > 0 && n == kill_at) raise(SIGKILL);
}

/* The next definition of `name` (libc's), looked up once. */
#define REAL(name)                            \
  static __typeof__(name)* real_##name;       \
  if (!real_##name) real_##name = (__typeof__(name)*)dlsym(RTLD_NEXT, #name)

static int writes(int flags) { return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC)) != 0; }

static mode_t mode_of(int flags, va_list args) {
  return (flags & O_CREAT) || (flags & O_TMPFILE) == O_TMPFILE ? (mode_t)va_arg(args, int) : 0;
}

int open(const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = mode_of(flags, args);
  va_end(args);
  REAL(open);
  if (writes(flags)) event("open", path);
  return real_open(path, flags, mode);
}

int open64(const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = mode_of(flags, args);
  va_end(args);
  REAL(open64);
  if (writes(flags)) event("open", path);
  return real_open64(path, flags, mode);
}

int openat(int dir, const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = mode_of(flags, args);
  va_end(args);
  REAL(openat);
  if (writes(flags)) event("open", path);
  return real_openat(dir, path, flags, mode);
}

int openat64(int dir, const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = mode_of(flags, args);
  va_end(args);
  REAL(openat64);
  if (writes(flags)) event("open", path);
  return real_openat64(dir, path, flags, mode);
}

int creat(const char* path, mode_t mode) {
  REAL(creat);
  event("open", path);
  return real_creat(path, mode);
}

int rename(const char* from, const char* to) {
  REAL(rename);
  event("rename", to);
  return real_rename(from, to);
}

int renameat(int from_dir, const char* from, int to_dir, const char* to) {
  REAL(renameat);
  event("rename", to);
  return real_renameat(from_dir, from, to_dir, to);
}

int renameat2(int from_dir, const char* from, int to_dir, const char* to, unsigned flags) {
  REAL(renameat2);
  event("rename", to);
  return real_renameat2(from_dir, from, to_dir, to, flags);
}

int unlink(const char* path) {
  REAL(unlink);
  event("unlink", path);
  return real_unlink(path);
}

int unlinkat(int dir, const char* path, int flags) {
  REAL(unlinkat);
  event("unlink", path);
  return real_unlinkat(dir, path, flags);
}

int remove(const char* path) {
  REAL(remove);
  event("unlink", path);
  return real_remove(path);
}

int rmdir(const char* path) {
  REAL(rmdir);
  event("rmdir", path);
  return real_rmdir(path);
}

int mkdir(const char* path, mode_t mode) {
  REAL(mkdir);
  event("mkdir", path);
  return real_mkdir(path, mode);
}

int mkdirat(int dir, const char* path, mode_t mode) {
  REAL(mkdirat);
  event("mkdir", path);
  return real_mkdirat(dir, path, mode);
}
