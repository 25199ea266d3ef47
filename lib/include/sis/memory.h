#pragma once
// What memory a request may use: the least of the system's available memory
// (MemAvailable plus free swap), the process's address-space and data
// limits (RLIMIT_AS, RLIMIT_DATA) less what it uses, and its cgroup's limit
// less the cgroup's usage. Requests are estimated against it before they
// allocate, so that what cannot fit is refused with a message rather than
// failing part way.
#include <cstdint>
#include <string>

namespace sis {

// Bytes this process can still allocate (UINT64_MAX when nothing says).
std::uint64_t available_memory();

// "9.3 GB", "512 MB": a size for messages.
std::string format_bytes(std::uint64_t bytes);

}  // namespace sis
