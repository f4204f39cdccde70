#include <rtsim/model/sim/ray_dispatch.h>

#include <rtsim/model/core/huge_pages.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rtsim::sim {

IssuePolicy IssuePolicy::from(const HardwareConfig& c) {
  IssuePolicy p;
  p.order = c.raygen_order == "scanline" ? Order::Scanline
            : c.raygen_order == "morton" ? Order::Morton
                                         : Order::Tiles;
  const auto [w, h] = parse_tile(c.raygen_tile);
  p.tile_width = w;
  p.tile_height = h;
  p.secondary_behind = c.raygen_secondary != "after";
  p.cores = c.cores;
  p.dynamic = c.raygen_dispatch == "dynamic";
  p.reorder = ReorderSettings::from(c);
  return p;
}

namespace {
uint64_t spread_bits(uint32_t v) {  // bit i of v to bit 2i
  uint64_t x = v;
  x = (x | (x << 16)) & 0x0000FFFF0000FFFFull;
  x = (x | (x << 8)) & 0x00FF00FF00FF00FFull;
  x = (x | (x << 4)) & 0x0F0F0F0F0F0F0F0Full;
  x = (x | (x << 2)) & 0x3333333333333333ull;
  x = (x | (x << 1)) & 0x5555555555555555ull;
  return x;
}
}  // namespace

std::vector<uint32_t> pixel_issue_order(uint32_t width, uint32_t height, const IssuePolicy& p) {
  std::vector<uint32_t> order;
  order.reserve(size_t(width) * height);
  switch (p.order) {
    case IssuePolicy::Order::Scanline:
      for (uint32_t i = 0; i < width * height; ++i) order.push_back(i);
      break;
    case IssuePolicy::Order::Tiles:
      for (uint32_t ty = 0; ty < height; ty += p.tile_height)
        for (uint32_t tx = 0; tx < width; tx += p.tile_width)
          for (uint32_t y = ty; y < std::min(height, ty + p.tile_height); ++y)
            for (uint32_t x = tx; x < std::min(width, tx + p.tile_width); ++x)
              order.push_back(y * width + x);
      break;
    case IssuePolicy::Order::Morton: {
      for (uint32_t i = 0; i < width * height; ++i) order.push_back(i);
      std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        const uint64_t ka = spread_bits(a % width) | (spread_bits(a / width) << 1);
        const uint64_t kb = spread_bits(b % width) | (spread_bits(b / width) << 1);
        return ka < kb;
      });
      break;
    }
  }
  return order;
}

std::vector<uint32_t> free_slot_order(uint32_t units, uint32_t slots_per_unit) {
  std::vector<uint32_t> order;
  order.reserve(size_t(units) * slots_per_unit);
  for (uint32_t s = 0; s < slots_per_unit; ++s)
    for (uint32_t u = 0; u < units; ++u) order.push_back(u * slots_per_unit + s);
  return order;
}

RayDispatcher::RayDispatcher(const IssuePolicy& policy, const std::vector<Ray>& initial, uint32_t width,
                             uint32_t height, bool spawn, const TraversalContext* context, uint64_t frame_rays)
    : policy_(policy), initial_count_(initial.size()), cores_(std::max<uint32_t>(1, policy.cores)) {
  // A bound far above the frame's share (glass doubles per bounce) is capped: the
  // array still grows past it if it must. On huge pages, reserved before the first
  // ray is written: the rays' first touch of fresh 4 KiB pages was the functional
  // level's largest kernel cost.
  const uint64_t room = std::min<uint64_t>(frame_rays, uint64_t(initial.size()) * 16 + 1024);
  reserve_on_huge_pages(rays_, size_t(std::max<uint64_t>(room, initial.size())));
  rays_.insert(rays_.end(), initial.begin(), initial.end());
  if (policy.reorder.batch_rays > 0) {
    if (!context) throw std::logic_error("ray dispatcher: a reordering unit needs the tree");
    reorder_ = std::make_unique<RayReorderUnit>(policy.reorder, uint32_t(cores_.size()), *context);
    wake_ps_.assign(cores_.size(), UINT64_MAX);
  }
  const size_t n = rays_.size();
  // Primary rays by pixel issue order (stable: a pixel's samples keep their order).
  const size_t pixel_count = size_t(width) * height;
  std::vector<uint32_t> rank(pixel_count, 0);
  const std::vector<uint32_t> pixels = pixel_issue_order(width, height, policy);
  for (uint32_t i = 0; i < pixels.size(); ++i) rank[pixels[i]] = i;
  const auto pixel_rank = [&](const Ray& r) { return r.pixel < rank.size() ? rank[r.pixel] : r.pixel; };
  // The tile a ray's pixel belongs to, numbered in issue order.
  const uint64_t tile_pixels = uint64_t(policy.tile_width) * policy.tile_height;
  const uint64_t tiles_across = (width + policy.tile_width - 1) / std::max<uint32_t>(1, policy.tile_width);
  const auto tile_of = [&](const Ray& r) -> uint64_t {
    if (policy.order == IssuePolicy::Order::Tiles && r.pixel < pixel_count)
      return uint64_t(r.pixel / width / policy.tile_height) * tiles_across +
             (r.pixel % width) / policy.tile_width;
    return pixel_rank(r) / tile_pixels;
  };
  std::vector<uint32_t> primaries;
  std::vector<std::vector<uint32_t>> children(spawn ? 0 : n);
  std::vector<uint32_t> others;
  for (uint32_t i = 0; i < n; ++i) {
    const Ray& r = rays_[i];
    const bool root = spawn || r.parent == kNoParent || r.parent >= n || r.parent >= i;
    if (root) primaries.push_back(i);
    else if (policy.secondary_behind) children[r.parent].push_back(i);
    else others.push_back(i);
  }
  std::stable_sort(primaries.begin(), primaries.end(), [&](uint32_t a, uint32_t b) {
    return pixel_rank(rays_[a]) < pixel_rank(rays_[b]);
  });
  std::vector<uint64_t> tile;  // per order_ entry
  if (spawn || !policy.secondary_behind) {
    order_ = primaries;
    order_.insert(order_.end(), others.begin(), others.end());
    for (uint32_t r : primaries) tile.push_back(tile_of(rays_[r]));
    // Replayed secondary rays issued after every primary: tiles of their own.
    for (uint32_t r : others) tile.push_back(UINT32_MAX + tile_of(rays_[r]));
  } else {
    // A replayed set, "behind": each root followed by its descendants, depth first,
    // all in the root's tile.
    order_.reserve(n);
    std::vector<uint32_t> stack;
    for (uint32_t p : primaries) {
      const uint64_t root_tile = tile_of(rays_[p]);
      stack.push_back(p);
      while (!stack.empty()) {
        const uint32_t r = stack.back();
        stack.pop_back();
        order_.push_back(r);
        tile.push_back(root_tile);
        for (auto it = children[r].rbegin(); it != children[r].rend(); ++it) stack.push_back(*it);
      }
    }
  }
  // One core issues the whole order as one tile; more cut it where the tile changes.
  tile_start_.push_back(0);
  if (cores_.size() > 1)
    for (size_t i = 1; i < order_.size(); ++i)
      if (tile[i] != tile[i - 1]) tile_start_.push_back(i);
  if (!order_.empty()) tile_start_.push_back(order_.size());  // no rays: no tiles
  start_frame(0);
}

void RayDispatcher::start_frame(uint64_t t) {
  for (uint32_t c = 0; c < cores_.size(); ++c) cores_[c] = CoreQueue{0, 0, c, {}};
  next_free_tile_ = 0;
  secondary_queued_ = 0;
  if (reorder_) reorder_->restart(t);
  for (uint64_t& w : wake_ps_) w = UINT64_MAX;
}

bool RayDispatcher::primary_left(const CoreQueue& q) const {
  const size_t tiles = tile_start_.size() - 1;
  return q.cursor < q.end || (policy_.dynamic ? next_free_tile_ : q.next_tile) < tiles;
}

bool RayDispatcher::take_tile(uint32_t core) {
  CoreQueue& q = cores_[core];
  const size_t tiles = tile_start_.size() - 1;
  size_t k;
  if (policy_.dynamic) {
    if (next_free_tile_ >= tiles) return false;
    k = next_free_tile_++;
  } else {
    if (q.next_tile >= tiles) return false;
    k = q.next_tile;
    q.next_tile += cores_.size();
  }
  q.cursor = tile_start_[k];
  q.end = tile_start_[k + 1];
  return true;
}

bool RayDispatcher::next(uint32_t core, uint64_t now_ps, uint32_t* ray_index) {
  if (!reorder_) return take(core, now_ps, ray_index);
  return reorder_->next(core, now_ps, rays_, ray_index, &wake_ps_[core],
                        [&](uint64_t t, uint32_t* ray) { return take(core, t, ray); });
}

uint64_t RayDispatcher::take_wake(uint32_t core) {
  if (wake_ps_.empty()) return UINT64_MAX;
  const uint64_t w = wake_ps_[core];
  wake_ps_[core] = UINT64_MAX;
  return w;
}

std::vector<Stage*> RayDispatcher::stages() {
  if (!reorder_) return {};
  return {reorder_.get()};
}

std::vector<const Stage*> RayDispatcher::stages() const {
  if (!reorder_) return {};
  return {reorder_.get()};
}

std::vector<StageDescription> RayDispatcher::stage_kinds() { return {RayReorderUnit::description()}; }

bool RayDispatcher::take(uint32_t core, uint64_t now_ps, uint32_t* ray_index) {
  CoreQueue& q = cores_[core];
  const bool secondary_ready = !q.secondary.empty() && q.secondary.front().ready_ps <= now_ps;
  const bool primary = primary_left(q);
  if (secondary_ready && (policy_.secondary_behind || !primary)) {
    *ray_index = q.secondary.front().ray;
    q.secondary.pop_front();
    --secondary_queued_;
    return true;
  }
  if (primary) {
    while (q.cursor == q.end)
      if (!take_tile(core)) return false;
    *ray_index = order_[q.cursor++];
    return true;
  }
  return false;
}

uint64_t RayDispatcher::next_ready_ps(uint32_t core) const {
  if (reorder_ && reorder_->holding(core)) return reorder_->ready_ps(core);
  const CoreQueue& q = cores_[core];
  if (primary_left(q)) return 0;
  return q.secondary.empty() ? UINT64_MAX : q.secondary.front().ready_ps;
}

bool RayDispatcher::empty() const {
  if (secondary_queued_ != 0) return false;
  if (reorder_ && reorder_->holding_any()) return false;
  for (const CoreQueue& q : cores_)
    if (primary_left(q)) return false;
  return true;
}

void RayDispatcher::add_spawned(uint32_t core, const std::vector<Ray>& rays, uint64_t ready_ps) {
  for (const Ray& r : rays) {
    cores_[core].secondary.push_back({uint32_t(rays_.size()), ready_ps});
    rays_.push_back(r);
  }
  secondary_queued_ += rays.size();
}

void RayDispatcher::restart(uint64_t frame_start_ps) {
  rays_.resize(initial_count_);
  start_frame(frame_start_ps);
}

}  // namespace rtsim::sim
