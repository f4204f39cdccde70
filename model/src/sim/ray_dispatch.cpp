#include <rtsim/model/sim/ray_dispatch.h>

#include <algorithm>
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

RayDispatcher::RayDispatcher(const IssuePolicy& policy, std::vector<Ray> initial, uint32_t width,
                             uint32_t height, bool spawn)
    : policy_(policy), rays_(std::move(initial)), initial_count_(rays_.size()) {
  const size_t n = rays_.size();
  // Primary rays by pixel issue order (stable: a pixel's samples keep their order).
  std::vector<uint32_t> rank(size_t(width) * height, 0);
  const std::vector<uint32_t> pixels = pixel_issue_order(width, height, policy);
  for (uint32_t i = 0; i < pixels.size(); ++i) rank[pixels[i]] = i;
  const auto pixel_rank = [&](const Ray& r) { return r.pixel < rank.size() ? rank[r.pixel] : r.pixel; };
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
  if (spawn || !policy.secondary_behind) {
    order_ = primaries;
    order_.insert(order_.end(), others.begin(), others.end());
    return;
  }
  // A replayed set, "behind": each root followed by its descendants, depth first.
  order_.reserve(n);
  std::vector<uint32_t> stack;
  for (uint32_t p : primaries) {
    stack.push_back(p);
    while (!stack.empty()) {
      const uint32_t r = stack.back();
      stack.pop_back();
      order_.push_back(r);
      for (auto it = children[r].rbegin(); it != children[r].rend(); ++it) stack.push_back(*it);
    }
  }
}

bool RayDispatcher::next(uint64_t now_ps, uint32_t* ray_index) {
  const bool secondary_ready = !secondary_.empty() && secondary_.front().ready_ps <= now_ps;
  const bool primary_left = cursor_ < order_.size();
  if (secondary_ready && (policy_.secondary_behind || !primary_left)) {
    *ray_index = secondary_.front().ray;
    secondary_.pop_front();
    return true;
  }
  if (primary_left) {
    *ray_index = order_[cursor_++];
    return true;
  }
  return false;
}

uint64_t RayDispatcher::next_ready_ps() const {
  if (cursor_ < order_.size()) return 0;
  return secondary_.empty() ? UINT64_MAX : secondary_.front().ready_ps;
}

void RayDispatcher::add_spawned(const std::vector<Ray>& rays, uint64_t ready_ps) {
  for (const Ray& r : rays) {
    secondary_.push_back({uint32_t(rays_.size()), ready_ps});
    rays_.push_back(r);
  }
}

void RayDispatcher::restart() {
  rays_.resize(initial_count_);
  cursor_ = 0;
  secondary_.clear();
}

}  // namespace rtsim::sim
