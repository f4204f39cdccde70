#pragma once
// fork() for a child that goes on running this program's code (not exec).
// A fork copies only the calling thread; locks that TBB's (and Embree's) worker
// threads hold at that moment stay held in the child for ever. So the workers are
// stopped first; the parent's next parallel call starts them again.
#include <sys/types.h>

namespace rtsim {

// Stops the worker threads if nothing keeps them alive (an open task arena or an
// Embree device), then forks. Returns what fork() returns.
pid_t fork_without_workers();

// Threads of this process now (from /proc/self/task); 0 if it cannot be read.
unsigned thread_count();

}  // namespace rtsim
