// Debian's libsystemc.so defines main() and needs an sc_main. rtsim executables
// have their own main() and drive the SystemC kernel directly (sc_start from the
// simulator), so this sc_main only satisfies the linker; model/CMakeLists.txt pulls
// it in with --undefined=sc_main. It runs only if SystemC's own main were chosen.
#include <cstdio>

extern "C" int sc_main(int, char**) {
  std::fprintf(stderr, "rtsim: SystemC's main() was linked instead of the program's own\n");
  return 1;
}
