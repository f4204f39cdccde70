#pragma once
// One ray's own trace (simulate | trace --trace-ray X,Y[,TYPE[,INDEX]]): every line
// request the ray makes, in the order it makes them, with the step it belongs to,
// the records it carries, read or write, which level served it, its latency and the
// cycle it went out. The core decides the requests (traversal.h), so the sequence is
// the same at every fidelity level and in `trace`; which level served each request
// and how long it took are what the levels differ in.
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/fetch.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/core/traversal.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

struct LineAccess;

// Which level answered a line request. A merge is a read of a line whose fill was
// already on its way (it waits for that miss); a write is taken by its L1 at once
// (write-allocate, posted). Functional levels know no DRAM rows: "DRAM".
enum class ServedBy : uint8_t {
  None, L1Hit, L1Merge, L1Write, L2Hit, L2Merge, Dram, DramRowHit, DramRowMiss, DramRowConflict
};
const char* served_by_name(ServedBy served);  // "L1 hit", "L1 MSHR merge", ..., "DRAM row conflict"
// The level as a hit, merge or miss of that level sees itself (level 1: L1, 2: L2).
inline ServedBy served_hit(int level) { return level == 1 ? ServedBy::L1Hit : ServedBy::L2Hit; }
inline ServedBy served_merge(int level) { return level == 1 ? ServedBy::L1Merge : ServedBy::L2Merge; }

// The ray the user asked for, by pixel, type and index. Primary rays: index is the
// sample. Secondary rays: the index-th ray of that type the pixel's rays spawn, in
// the order the core spawns them (samples in order, each ray's children in spawn
// order, breadth first). Finds it by tracing that pixel alone with the functional
// core, so the ray is the very one every level traces. Throws InputError naming
// --trace-ray when the pixel has no such ray.
struct RayTarget {
  uint32_t x = 0, y = 0;
  RayType type = RayType::Primary;
  uint32_t index = 0;
};
// "X,Y[,TYPE[,INDEX]]" with the strict number reader; InputError naming --trace-ray.
RayTarget parse_ray_target(const std::string& text, uint32_t width, uint32_t height);
Ray find_target_ray(const RayTarget& target, const TraversalContext& context, const Camera* camera,
                    const EffectSettings& settings, const EffectPlan& plan,
                    const std::vector<Ray>& replayed);

class RayProbe {
 public:
  explicit RayProbe(const Ray& ray) : target_(ray) {}
  // The target itself: every field that makes the ray (not its parent's index,
  // which depends on the order rays finish in).
  bool is(const Ray& ray) const;
  const Ray& target() const { return target_; }

  // The target starts (again, in a later frame: the last frame's trace is kept).
  void begin(uint64_t t_ps);
  void next_step() { ++step_; }
  // Line requests of one part of a step as the engine sends them (the step's
  // reads, the reads behind a prim-ref list, or its stack traffic): `lines` are
  // the requests `accesses` make, in L1 lines of node_line_bytes (nodes, stack),
  // triangle_line_bytes (prim refs, triangles) and texture_line_bytes (UVs, texels).
  // Returns the first request's number.
  uint32_t add(const MemoryAccess* accesses, size_t count, const LineAccess* lines, size_t line_count,
               uint32_t node_line_bytes, uint32_t triangle_line_bytes, uint32_t texture_line_bytes,
               uint64_t issue_ps);
  void served(uint32_t request, ServedBy by, uint64_t done_ps);
  void end(uint64_t t_ps, const RayCounters& counters);

  struct Request {
    uint32_t step = 0;
    AccessKind kind = AccessKind::Node;
    bool write = false;
    uint64_t line = 0;
    uint32_t bytes = 0;
    std::vector<uint32_t> carries;  // the MemoryAccesses (by number in accesses()) it carries
    ServedBy served = ServedBy::None;
    uint64_t issue_ps = 0, done_ps = 0;
  };
  const std::vector<Request>& requests() const { return requests_; }
  const std::vector<MemoryAccess>& accesses() const { return accesses_; }
  bool seen() const { return seen_; }
  uint64_t start_ps() const { return start_ps_; }
  uint64_t end_ps() const { return end_ps_; }
  const RayCounters& counters() const { return counters_; }

 private:
  Ray target_;
  uint32_t step_ = 0;
  std::vector<Request> requests_;
  std::vector<MemoryAccess> accesses_;
  bool seen_ = false;
  uint64_t start_ps_ = 0, end_ps_ = 0;
  RayCounters counters_;
};

// The trace as JSON (requests with the records they carry by node, leaf, triangle or
// stack entry, and the ray's totals) and as a text table. Times relative to
// `frame_start_ps`, in cycles of `cycle_ps`; timed = false: no latencies (functional).
nlohmann::json ray_trace_json(const RayProbe& probe, const RayTarget& target, const MemoryImage& image,
                              const TraversalContext& context, double cycle_ps, uint64_t frame_start_ps,
                              bool timed);
std::string ray_trace_text(const nlohmann::json& trace);

}  // namespace rtsim::sim
