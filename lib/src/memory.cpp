#include "sis/memory.h"

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace sis {

namespace {

constexpr std::uint64_t kNone = std::numeric_limits<std::uint64_t>::max();

// A "Key:   N kB" line of /proc/meminfo or /proc/self/status, in bytes.
std::uint64_t kb_field(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key + ":", 0) == 0) {
      std::istringstream s(line.substr(key.size() + 1));
      std::uint64_t kb = 0;
      if (s >> kb) return kb * 1024;
    }
  return kNone;
}

std::uint64_t limit_left(int resource, const char* used_key) {
  rlimit r{};
  if (getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return kNone;
  const std::uint64_t used = kb_field("/proc/self/status", used_key);
  if (used == kNone) return std::uint64_t(r.rlim_cur);
  return std::uint64_t(r.rlim_cur) > used ? std::uint64_t(r.rlim_cur) - used : 0;
}

// cgroup v2: memory.max less memory.current of this process's group.
std::uint64_t cgroup_left() {
  std::ifstream self("/proc/self/cgroup");
  std::string line, path;
  while (std::getline(self, line))
    if (line.rfind("0::", 0) == 0) path = line.substr(3);
  if (path.empty()) return kNone;
  const std::string dir = "/sys/fs/cgroup" + path;
  std::ifstream max(dir + "/memory.max"), cur(dir + "/memory.current");
  std::string m;
  std::uint64_t limit = 0, used = 0;
  if (!(max >> m) || m == "max") return kNone;
  try {
    limit = std::stoull(m);
  } catch (...) {
    return kNone;
  }
  if (!(cur >> used)) return limit;
  return limit > used ? limit - used : 0;
}

}  // namespace

std::uint64_t available_memory() {
  std::uint64_t system = kb_field("/proc/meminfo", "MemAvailable");
  const std::uint64_t swap = kb_field("/proc/meminfo", "SwapFree");
  if (system != kNone && swap != kNone) system += swap;
  return std::min({system, limit_left(RLIMIT_AS, "VmSize"), limit_left(RLIMIT_DATA, "VmData"),
                   cgroup_left()});
}

std::string format_bytes(std::uint64_t bytes) {
  char buf[32];
  if (bytes >= (std::uint64_t(1) << 30))
    std::snprintf(buf, sizeof buf, "%.1f GB", double(bytes) / double(1 << 30));
  else
    std::snprintf(buf, sizeof buf, "%.0f MB", double(bytes) / double(1 << 20));
  return buf;
}

}  // namespace sis
