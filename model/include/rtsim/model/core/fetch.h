#pragma once
// Every memory read the traversal issues, before any cache: the functional cache
// simulator, statistics and trace writers plug in as a FetchSink.
#include <rtsim/model/core/ray.h>

#include <cstdint>

namespace rtsim {

enum class FetchKind : uint8_t { Node = 0, PrimRef = 1, Triangle = 2 };
constexpr int kFetchKindCount = 3;
const char* fetch_kind_name(FetchKind kind);  // "node", "prim_ref", "triangle"

struct Fetch {
  uint64_t address = 0;  // byte address in the MemoryImage
  uint32_t bytes = 0;
  FetchKind kind = FetchKind::Node;
  RayType ray_type = RayType::Primary;
};

class FetchSink {
 public:
  virtual ~FetchSink() = default;
  virtual void on_fetch(const Fetch& fetch) = 0;
};

}  // namespace rtsim
