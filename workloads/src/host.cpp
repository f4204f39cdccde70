#include <rtsim/workloads/host.h>

#include <sys/resource.h>

namespace rtsim {

uint64_t peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace rtsim
