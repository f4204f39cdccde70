#pragma once
// Every memory access the traversal makes, before any cache: what the functional
// cache simulator, the SystemC units, statistics and trace writers consume. The
// traversal core decides them (RayTraversal::step_reads, stack_accesses); the
// drivers only time them.
#include <rtsim/model/core/ray.h>

#include <cstdint>

namespace rtsim {

// Uv and Texel: the any-hit stage's reads of an alpha-tested triangle's texture
// coordinates and of the texel they pick (through the texture cache).
enum class AccessKind : uint8_t { Node = 0, PrimRef = 1, Triangle = 2, Stack = 3, Uv = 4, Texel = 5, Instance = 6 };
constexpr int kAccessKindCount = 7;
// "node", "prim_ref", "triangle", "stack", "uv", "texel", "instance"
const char* access_kind_name(AccessKind kind);

struct MemoryAccess {
  uint64_t address = 0;  // byte address in the MemoryImage (or the stack spill area)
  uint32_t bytes = 0;
  AccessKind kind = AccessKind::Node;
  bool write = false;    // only stack spills write
};

class AccessSink {
 public:
  virtual ~AccessSink() = default;
  virtual void on_access(const MemoryAccess& access, RayType ray_type) = 0;
  // After the accesses of one step (its reads and the stack traffic it caused):
  // a unit sends one request per line and step.
  virtual void on_step_end() {}
};

}  // namespace rtsim
