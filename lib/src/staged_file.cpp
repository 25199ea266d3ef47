#include "sis/staged_file.h"

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <vector>

#include "sis/imageio.h"

namespace sis {

namespace fs = std::filesystem;

namespace {

// The registry of temporary files that exist: fixed slots the signal
// handler reads without locks or allocation (a slot's path is written
// before its flag is raised).
constexpr int kSlots = 64;
struct Slot {
  std::atomic<int> active{0};
  char path[PATH_MAX + 1];
};
Slot registry[kSlots];
std::mutex registry_mutex;  // claiming and releasing slots (not the handler)

// Signals sent to the process, held while a staged file is created or
// removed.
const int kCleanupSignals[] = {SIGINT,  SIGTERM, SIGHUP,  SIGQUIT,   SIGPIPE, SIGALRM,
                               SIGXCPU, SIGUSR1, SIGUSR2, SIGVTALRM};
// Signals of a failure in the process itself (an abort in a library, a
// fault): never held (a fault while held ends the process unhandled), and
// handled on an alternate stack where there is one (a stack overflow).
const int kFatalSignals[] = {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGSYS};

static_assert(std::atomic<int>::is_always_lock_free, "the handler reads the slots' flags");

// Async-signal-safe: atomic loads, unlink, signal and raise only. The
// signal raised again is blocked until the handler returns; a fault's
// instruction, run again, then faults under the default action.
extern "C" void remove_and_reraise(int sig) {
  for (Slot& s : registry)
    if (s.active.load()) ::unlink(s.path);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// The process's umask, read once before any thread runs (umask() can only
// be read by setting it).
const mode_t kUmask = [] {
  const mode_t m = ::umask(022);
  ::umask(m);
  return m;
}();

// Blocks the cleanup signals while it lives: a temporary file is created
// and registered, or unregistered and removed, with no signal in between.
class SignalsHeld {
 public:
  SignalsHeld() {
    sigset_t set;
    sigemptyset(&set);
    for (int s : kCleanupSignals) sigaddset(&set, s);
    pthread_sigmask(SIG_BLOCK, &set, &old_);
  }
  ~SignalsHeld() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

}  // namespace

StagedFile::StagedFile(const std::string& target) : target_(target) {
  check_path(target, true);
  const fs::path t(target);
  const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw OutputError(target + ": folder " + dir.string() + " does not exist");
  if (fs::is_directory(t, ec)) throw OutputError(target + ": is a folder");
  // .NAME.sis-XXXXXX.EXT: hidden, and with the target's extension; without
  // NAME where that would pass the longest name the folder takes.
  const std::string ext = t.extension().string();
  std::string leaf = "." + t.stem().string() + ".sis-XXXXXX" + ext;
  const long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX);
  if (long(leaf.size()) > (name_max > 0 ? name_max : 255)) leaf = ".sis-XXXXXX" + ext;
  std::string name = (dir / leaf).string();
  if (name.size() > PATH_MAX) throw OutputError(target + ": file name too long");
  SignalsHeld held;
  std::lock_guard<std::mutex> lock(registry_mutex);
  for (int i = 0; i < kSlots; ++i)
    if (!registry[i].active.load()) {
      slot_ = i;
      break;
    }
  if (slot_ < 0) throw OutputError(target + ": too many output files at once");
  Slot& s = registry[slot_];
  std::memcpy(s.path, name.c_str(), name.size() + 1);
  // Registered before it exists: a signal handled on another thread (the
  // mask above holds this thread's only) as mkostemps names and creates it
  // removes it.
  s.active.store(1);
  fd_ = ::mkostemps(s.path, int(ext.size()), O_CLOEXEC);
  if (fd_ < 0) {
    const int e = errno;
    s.active.store(0);
    slot_ = -1;
    throw OutputError(target + ": cannot create a file in folder " + dir.string() + ": " +
                      std::strerror(e));
  }
  temporary_ = s.path;
  // mkostemps creates 0600. A file that replaces another keeps its
  // permissions (and its owner and group where the user may give them), as
  // a file rewritten in place would; a new one gets a new file's.
  struct stat old;
  if (::stat(target.c_str(), &old) == 0 && S_ISREG(old.st_mode)) {
    ::fchmod(fd_, old.st_mode & 07777);
    if (::fchown(fd_, old.st_uid, old.st_gid) != 0) {  // not permitted: the user's own
    }
  } else {
    ::fchmod(fd_, 0666 & ~kUmask);
  }
}

StagedFile::StagedFile(StagedFile&& o) noexcept
    : target_(std::move(o.target_)),
      temporary_(std::move(o.temporary_)),
      fd_(o.fd_),
      slot_(o.slot_),
      committed_(o.committed_) {
  o.fd_ = -1;
  o.slot_ = -1;
  o.committed_ = true;
}

StagedFile::~StagedFile() {
  if (fd_ >= 0) ::close(fd_);
  if (slot_ < 0) return;
  SignalsHeld held;
  std::lock_guard<std::mutex> lock(registry_mutex);
  if (!committed_) ::unlink(temporary_.c_str());
  registry[slot_].active.store(0);
}

void StagedFile::close() {
  if (fd_ < 0) return;
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0)
    throw OutputError(target_ + ": cannot finish writing: " + std::strerror(errno));
}

void StagedFile::commit() {
  if (committed_) throw std::logic_error("StagedFile::commit(): committed already");
  close();
  SignalsHeld held;
  std::lock_guard<std::mutex> lock(registry_mutex);
  if (::rename(temporary_.c_str(), target_.c_str()) != 0)
    throw OutputError(target_ + ": cannot rename the finished file into place: " +
                      std::strerror(errno));
  committed_ = true;
  registry[slot_].active.store(0);
  slot_ = -1;
}

void remove_staged_files_on_signals() {
  // An alternate stack for this thread's handler, unless it has one.
  static char alternate[1 << 16];
  stack_t current;
  if (sigaltstack(nullptr, &current) == 0 && (current.ss_flags & SS_DISABLE)) {
    stack_t st;
    st.ss_sp = alternate;
    st.ss_size = sizeof alternate;
    st.ss_flags = 0;
    sigaltstack(&st, nullptr);
  }
  auto install = [](int sig) {
    struct sigaction old;
    if (sigaction(sig, nullptr, &old) != 0 || old.sa_handler == SIG_IGN) return;
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = remove_and_reraise;
    sa.sa_flags = SA_ONSTACK;
    sigemptyset(&sa.sa_mask);
    for (int s : kCleanupSignals) sigaddset(&sa.sa_mask, s);
    for (int s : kFatalSignals) sigaddset(&sa.sa_mask, s);
    sigaction(sig, &sa, nullptr);
  };
  for (int sig : kCleanupSignals) install(sig);
  for (int sig : kFatalSignals) install(sig);
  struct sigaction old;
  if (sigaction(SIGXFSZ, nullptr, &old) == 0 && old.sa_handler == SIG_DFL) ::signal(SIGXFSZ, SIG_IGN);
}

namespace {
// The scopes' shared install: how many live, and the actions they replaced.
std::mutex scopes_mutex;
int scopes = 0;
struct Replaced {
  int sig;
  struct sigaction old;
};
std::vector<Replaced> replaced;
}  // namespace

StagedFileSignals::StagedFileSignals() {
  std::lock_guard<std::mutex> lock(scopes_mutex);
  if (scopes++ > 0) return;
  for (int sig : kCleanupSignals) {
    struct sigaction old;
    if (sigaction(sig, nullptr, &old) != 0 || (old.sa_flags & SA_SIGINFO) ||
        old.sa_handler != SIG_DFL)
      continue;
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = remove_and_reraise;
    sigemptyset(&sa.sa_mask);
    for (int s : kCleanupSignals) sigaddset(&sa.sa_mask, s);
    if (sigaction(sig, &sa, nullptr) == 0) replaced.push_back({sig, old});
  }
}

StagedFileSignals::~StagedFileSignals() {
  std::lock_guard<std::mutex> lock(scopes_mutex);
  if (--scopes > 0) return;
  for (const Replaced& r : replaced) sigaction(r.sig, &r.old, nullptr);
  replaced.clear();
}

}  // namespace sis
