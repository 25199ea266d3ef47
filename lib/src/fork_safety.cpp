#include "sis/parallel.h"

#include <OpenEXR/ImfThreading.h>
#include <dlfcn.h>
#include <link.h>
#include <pthread.h>

#include <cstring>
#include <mutex>

namespace sis {

namespace {

// A child of fork() has only the thread that forked. Pools of threads the
// parent started are gone in it, and a library that joins its pool's
// threads at the process's exit, or hands them work, then waits for ever.
// The library's own pool is made anew in the child (parallel.cpp); the
// pools of its dependencies are stopped before the fork and started again
// in the parent after it:
// - OpenEXR's global thread pool (OpenImageIO decodes and encodes EXR on
//   it): its count set to 0 (its threads joined) and back in the parent;
//   the child decodes in its calling threads until OpenImageIO sets the
//   count again.
// - log4cplus 2.0 (Debian's OpenImageIO loads OpenVDB, which loads it)
//   starts a pool of threads when loaded and joins them at exit; nothing in
//   the process logs through it, and 2.0 has no call to start it again:
//   its own shutdownThreadPool() (exported, not declared in 2.0's headers)
//   stops it for good before the first fork. The library is found among
//   those loaded by name: a dependency of a dlopen'ed module (the Python
//   module) is not in the global scope dlsym(RTLD_DEFAULT) searches.
int exr_threads = 0;
void (*log4cplus_shutdown_thread_pool)() = nullptr;

void find_log4cplus() {
  dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t, void*) {
        if (!info->dlpi_name || !std::strstr(info->dlpi_name, "liblog4cplus")) return 0;
        void* lib = dlopen(info->dlpi_name, RTLD_LAZY | RTLD_NOLOAD);
        if (!lib) return 0;
        if (void* f = dlsym(lib, "_ZN9log4cplus18shutdownThreadPoolEv"))
          log4cplus_shutdown_thread_pool = reinterpret_cast<void (*)()>(f);
        return 1;  // the handle is kept: the library stays loaded
      },
      nullptr);
}

void before_fork() {
  if (log4cplus_shutdown_thread_pool) {
    log4cplus_shutdown_thread_pool();
    log4cplus_shutdown_thread_pool = nullptr;  // once: it stays shut
  }
  exr_threads = Imf::globalThreadCount();
  if (exr_threads > 0) Imf::setGlobalThreadCount(0);
}

void after_fork_in_parent() {
  if (exr_threads > 0) Imf::setGlobalThreadCount(exr_threads);
}

}  // namespace

void keep_fork_safe() {
  static std::once_flag once;
  std::call_once(once, [] {
    find_log4cplus();
    pthread_atfork(before_fork, after_fork_in_parent, nullptr);
  });
}

}  // namespace sis
