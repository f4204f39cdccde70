#include <rtsim/workloads/fork.h>

#include <tbb/global_control.h>

#include <dirent.h>
#include <unistd.h>

#include <new>

namespace rtsim {

pid_t fork_without_workers() {
  tbb::task_scheduler_handle handle{tbb::attach{}};
  // false when an arena or an Embree device still holds the scheduler: then the
  // workers stay, as before, and the child must not need a lock they might hold.
  (void)tbb::finalize(handle, std::nothrow);
  return ::fork();
}

unsigned thread_count() {
  DIR* dir = ::opendir("/proc/self/task");
  if (!dir) return 0;
  unsigned n = 0;
  while (const dirent* e = ::readdir(dir))
    if (e->d_name[0] != '.') ++n;
  ::closedir(dir);
  return n;
}

}  // namespace rtsim
