// A test-only interposer (LD_PRELOAD) that numbers a process's file events and kills it at one of them, so a
// fault harness can reach every window between two writes, not only the moments a timer happens to hit.
//
// Events, numbered from 1 in the order the process makes them: an open for writing, a write to a regular file,
// an fsync, a rename, an unlink or remove, a mkdir. Writes to the terminal, pipes and the standard streams are not
// events (they are not files a resume reads).
//   CELLDEM_KILL_LOG=FILE   appends "N op path" for each event (to count a run's events), the event a kill lands at
//                           marked " KILL" (the last line of a killed process's log)
//   CELLDEM_KILL_AT=N       SIGKILL at event N ...
//   CELLDEM_KILL_WHEN=when  ... "before" it happens, "after" it (the default), or "torn": a write of half its
//                           bytes, then the kill (a row or a state cut short, as a full disk or a crash leaves it)
// The kill is SIGKILL: no handler, no flush, exactly what a batch system's hard limit or a power cut leaves.
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

enum when { kAfter, kBefore, kTorn };

static atomic_long g_events;
static long g_kill_at = -1;
static enum when g_when = kAfter;
static int g_log = -1;

__attribute__((constructor)) static void kill_at_init(void) {
  const char* at = getenv("CELLDEM_KILL_AT");
  if (at && *at) g_kill_at = atol(at);
  const char* when = getenv("CELLDEM_KILL_WHEN");
  if (when && strcmp(when, "before") == 0) g_when = kBefore;
  if (when && strcmp(when, "torn") == 0) g_when = kTorn;
  const char* log = getenv("CELLDEM_KILL_LOG");
  if (log && *log) g_log = (int)syscall(SYS_openat, AT_FDCWD, log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
}

static void die(void) {
  syscall(SYS_kill, getpid(), SIGKILL);
  for (;;) pause();
}

// Numbers the event, logs it, and kills before it when that is asked: its number (the caller kills after it).
static long event(const char* op, const char* path) {
  const long n = atomic_fetch_add(&g_events, 1) + 1;
  if (g_log >= 0) {
    char line[4200];
    const int len = snprintf(line, sizeof line, "%ld %s %s%s\n", n, op, path ? path : "?", n == g_kill_at ? " KILL" : "");
    if (len > 0) syscall(SYS_write, g_log, line, (size_t)(len < (int)sizeof line ? len : (int)sizeof line - 1));
  }
  if (n == g_kill_at && g_when == kBefore) die();
  return n;
}
static void after(long n) {
  if (n == g_kill_at) die();
}

// `call` as event `op` on `path`: numbered (and killed before, when asked) ahead of it, killed after it when asked.
#define AROUND(op, path, call)       \
  __extension__({                    \
    const long n_ = event(op, path); \
    __typeof__(call) r_ = call;      \
    after(n_);                       \
    r_;                              \
  })
// open's third argument, there only with O_CREAT or O_TMPFILE (whose bits include O_DIRECTORY's).
#define MODE_ARG(flags, mode)                                  \
  if ((flags & O_CREAT) || (flags & O_TMPFILE) == O_TMPFILE) { \
    va_list ap;                                                \
    va_start(ap, flags);                                       \
    mode = va_arg(ap, mode_t);                                 \
    va_end(ap);                                                \
  }

static int regular_file(int fd) {
  struct stat st;
  return fd > 2 && syscall(SYS_fstat, fd, &st) == 0 && S_ISREG(st.st_mode);
}
static const char* fd_path(int fd, char* buf, size_t size) {
  char link[64];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, buf, size - 1);
  buf[n > 0 ? n : 0] = '\0';
  return buf;
}

// The next definition of `name` (libc's), looked up once (memcpy: ISO C has no cast from dlsym's pointer).
#define REAL(name) \
  static __typeof__(name)* real_##name; \
  if (!real_##name) { void* found = dlsym(RTLD_NEXT, #name); memcpy(&real_##name, &found, sizeof found); }

static int writes(int flags) { return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND)) != 0; }

int open(const char* path, int flags, ...) {
  REAL(open);
  mode_t mode = 0;
  MODE_ARG(flags, mode);
  if (!writes(flags)) return real_open(path, flags, mode);
  return AROUND("open", path, real_open(path, flags, mode));
}
int open64(const char* path, int flags, ...) {
  REAL(open64);
  mode_t mode = 0;
  MODE_ARG(flags, mode);
  if (!writes(flags)) return real_open64(path, flags, mode);
  return AROUND("open", path, real_open64(path, flags, mode));
}
int openat(int dir, const char* path, int flags, ...) {
  REAL(openat);
  mode_t mode = 0;
  MODE_ARG(flags, mode);
  if (!writes(flags)) return real_openat(dir, path, flags, mode);
  return AROUND("open", path, real_openat(dir, path, flags, mode));
}
FILE* fopen(const char* path, const char* how) {
  REAL(fopen);
  if (!strpbrk(how, "wa+")) return real_fopen(path, how);
  return AROUND("open", path, real_fopen(path, how));
}
FILE* fopen64(const char* path, const char* how) {
  REAL(fopen64);
  if (!strpbrk(how, "wa+")) return real_fopen64(path, how);
  return AROUND("open", path, real_fopen64(path, how));
}

ssize_t write(int fd, const void* bytes, size_t count) {
  REAL(write);
  if (!regular_file(fd)) return real_write(fd, bytes, count);
  char path[4096];
  const long n = event("write", fd_path(fd, path, sizeof path));
  if (n == g_kill_at && g_when == kTorn) {
    real_write(fd, bytes, count / 2);
    die();
  }
  const ssize_t done = real_write(fd, bytes, count);
  after(n);
  return done;
}

int fsync(int fd) {
  REAL(fsync);
  char path[4096];
  return AROUND("fsync", fd_path(fd, path, sizeof path), real_fsync(fd));
}

int rename(const char* from, const char* to) {
  REAL(rename);
  return AROUND("rename", to, real_rename(from, to));
}
int renameat(int fd_from, const char* from, int fd_to, const char* to) {
  REAL(renameat);
  return AROUND("rename", to, real_renameat(fd_from, from, fd_to, to));
}

int unlink(const char* path) {
  REAL(unlink);
  return AROUND("unlink", path, real_unlink(path));
}
int unlinkat(int dir, const char* path, int flags) {
  REAL(unlinkat);
  return AROUND("unlink", path, real_unlinkat(dir, path, flags));
}
int remove(const char* path) {
  REAL(remove);
  return AROUND("unlink", path, real_remove(path));
}
int rmdir(const char* path) {
  REAL(rmdir);
  return AROUND("unlink", path, real_rmdir(path));
}
int mkdir(const char* path, mode_t mode) {
  REAL(mkdir);
  return AROUND("mkdir", path, real_mkdir(path, mode));
}
