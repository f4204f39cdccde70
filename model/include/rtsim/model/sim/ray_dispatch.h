#pragma once
// Which ray the accelerator issues next: one policy for the functional, lt and
// cycle levels (the ray-generation unit's issue order).
//  - Primary rays in raygen.order: scanline, tiles of raygen.tile (rows within a
//    tile, tiles row by row), or Morton order of the pixel; a pixel's samples
//    stay together.
//  - Secondary rays (spawned by shading, or replayed from a ray set with parent
//    links) either right behind their parent, ahead of new primary rays
//    ("behind"), or after every primary ray ("after").
// Rays go to free TRV slots in the order the slots became free; at the start
// every slot is free, slot 0 of every unit first, then slot 1, ... so that rays
// spread over the units (free_slot_order).
// With several cores the issue order is cut into tiles of raygen.tile pixels
// (the screen tiles for raygen.order = tiles, runs of that many pixels in the
// issue order otherwise) and each core issues its tiles in order: tile i goes to
// core i mod cores (static), or a core that finishes its tile takes the next one
// not yet taken (dynamic). A core's spawned rays queue on that core. One core
// issues exactly the single order above.
// The stages (units/stage.h) sit on this path: with reorder.batch_rays > 0 each
// core's rays pass its ray-reordering unit (ray_reorder.h) on their way to TRV.
// next() is where every level meets them; stages() is how the rest reaches them.
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/ray_reorder.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

namespace rtsim::sim {

struct IssuePolicy {
  enum class Order { Scanline, Tiles, Morton } order = Order::Tiles;
  uint32_t tile_width = 8, tile_height = 8;
  bool secondary_behind = true;
  uint32_t cores = 1;
  bool dynamic = false;  // raygen.dispatch
  ReorderSettings reorder;  // batch_rays 0: no reordering unit
  static IssuePolicy from(const HardwareConfig& config);
};

// Pixel issue order of a width x height image (indices y * width + x).
std::vector<uint32_t> pixel_issue_order(uint32_t width, uint32_t height, const IssuePolicy& policy);

// Global slot ids (unit * slots_per_unit + slot) in the order rays fill them at the start.
std::vector<uint32_t> free_slot_order(uint32_t units, uint32_t slots_per_unit);

class RayDispatcher {
 public:
  // initial: the frame's rays. spawn = true: they are primary rays and shading
  // adds secondary rays (add_spawned); false: a replayed ray set, ordered once
  // with its parent links. context: the tree the stages read (only with a stage).
  // frame_rays: the frame's rays in all, initial and spawned (frame_ray_bound), for
  // which rays() has room before the frame runs: a frame of a million rays
  // otherwise grows the array twenty times, each a copy of all of it onto fresh
  // pages.
  RayDispatcher(const IssuePolicy& policy, const std::vector<Ray>& initial, uint32_t width,
                uint32_t height, bool spawn, const TraversalContext* context = nullptr,
                uint64_t frame_rays = 0);

  // The next ray core `core` issues that is ready at now_ps (index into rays();
  // UINT64_MAX: untimed); false if none.
  bool next(uint32_t core, uint64_t now_ps, uint32_t* ray_index);
  // After a next() that returned false: when a stage of the core releases the
  // rays it just took in, once (UINT64_MAX: nothing held). The level wakes the
  // core's ray generation then.
  uint64_t take_wake(uint32_t core);
  // Earliest time a ray queued for the core is ready (UINT64_MAX: nothing queued).
  uint64_t next_ready_ps(uint32_t core) const;
  bool empty() const;  // nothing queued for any core
  // The stages this run built, in path order, and every kind it can build.
  std::vector<Stage*> stages();
  std::vector<const Stage*> stages() const;
  static std::vector<StageDescription> stage_kinds();
  const RayReorderUnit* reorder_unit() const { return reorder_.get(); }  // null: not built
  // Rays a core's shading spawned (ready at ready_ps), appended to rays().
  void add_spawned(uint32_t core, const std::vector<Ray>& rays, uint64_t ready_ps);
  const std::vector<Ray>& rays() const { return rays_; }
  // The next frame, from frame_start_ps: the same initial rays again (shading spawns
  // the same secondaries).
  void restart(uint64_t frame_start_ps = 0);
  uint32_t cores() const { return uint32_t(cores_.size()); }

 private:
  struct Spawned {
    uint32_t ray;
    uint64_t ready_ps;
  };
  struct CoreQueue {
    size_t cursor = 0, end = 0;  // the core's current tile: order_[cursor, end)
    size_t next_tile = 0;        // static: the next tile it owns
    std::deque<Spawned> secondary;
  };
  bool take(uint32_t core, uint64_t now_ps, uint32_t* ray_index);  // ray generation's next ray
  bool primary_left(const CoreQueue& q) const;
  bool take_tile(uint32_t core);  // moves the core to its next tile; false if none
  void start_frame(uint64_t t);

  IssuePolicy policy_;
  std::vector<Ray> rays_;
  size_t initial_count_;
  std::vector<uint32_t> order_;       // issue order of the initial rays
  std::vector<size_t> tile_start_;    // order_ cut into tiles; one past the end last
  size_t next_free_tile_ = 0;         // dynamic
  size_t secondary_queued_ = 0;
  std::vector<CoreQueue> cores_;
  std::unique_ptr<RayReorderUnit> reorder_;  // null: no unit
  std::vector<uint64_t> wake_ps_;          // per core, for take_wake
};

}  // namespace rtsim::sim
