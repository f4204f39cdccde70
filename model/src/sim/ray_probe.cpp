#include <rtsim/model/sim/ray_probe.h>
#include <rtsim/model/sim/ray_engine.h>

#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/numbers.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <sstream>
#include <unordered_map>

namespace rtsim::sim {

const char* served_by_name(ServedBy served) {
  switch (served) {
    case ServedBy::None: return "-";
    case ServedBy::L1Hit: return "L1 hit";
    case ServedBy::L1Merge: return "L1 MSHR merge";
    case ServedBy::L1Write: return "L1 write (posted)";
    case ServedBy::L2Hit: return "L2 hit";
    case ServedBy::L2Merge: return "L2 MSHR merge";
    case ServedBy::Dram: return "DRAM";
    case ServedBy::DramRowHit: return "DRAM row hit";
    case ServedBy::DramRowMiss: return "DRAM row miss";
    case ServedBy::DramRowConflict: return "DRAM row conflict";
  }
  return "?";
}


RayTarget parse_ray_target(const std::string& text, uint32_t width, uint32_t height) {
  const std::string flag = "--trace-ray";
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
  if (!text.empty() && text.back() == ',') parts.push_back("");
  if (parts.size() < 2 || parts.size() > 4)
    throw InputError(flag, "expected X,Y[,TYPE[,INDEX]], got '" + text + "'");
  RayTarget t;
  t.x = uint32_t(read_unsigned(parts[0], 0, width - 1, flag + " X (the image is " + std::to_string(width) +
                                                              " pixels wide)"));
  t.y = uint32_t(read_unsigned(parts[1], 0, height - 1, flag + " Y (the image is " + std::to_string(height) +
                                                               " pixels high)"));
  if (parts.size() >= 3) {
    bool known = false;
    std::string names;
    for (RayType type : kAllRayTypes) {
      names += std::string(names.empty() ? "" : " | ") + ray_type_name(type);
      if (parts[2] == ray_type_name(type)) t.type = type, known = true;
    }
    if (!known) throw InputError(flag + " TYPE", "unknown ray type '" + parts[2] + "' (" + names + ")");
  }
  if (parts.size() == 4) t.index = uint32_t(read_unsigned(parts[3], 0, UINT32_MAX, flag + " INDEX"));
  return t;
}

Ray find_target_ray(const RayTarget& target, const TraversalContext& context, const Camera* camera,
                    const EffectSettings& settings, const EffectPlan& plan,
                    const std::vector<Ray>& replayed) {
  const uint32_t pixel = target.y * settings.width + target.x;
  const std::string what = std::string(ray_type_name(target.type)) + " ray " + std::to_string(target.index) +
                           " of pixel " + std::to_string(target.x) + "," + std::to_string(target.y);
  if (!replayed.empty()) {
    uint32_t seen = 0;
    for (const Ray& r : replayed)
      if (r.pixel == pixel && r.type == target.type && seen++ == target.index) return r;
    throw InputError("--trace-ray", "the ray set has no " + what + " (" + std::to_string(seen) +
                                        " rays of that type and pixel)");
  }
  if (!camera) throw InputError("--trace-ray", "no camera to make the pixel's rays from");
  // The pixel's rays in spawn order, breadth first: its samples, then their children.
  std::deque<Ray> queue;
  for (uint32_t s = 0; s < std::max(1u, settings.spp); ++s)
    queue.push_back(make_primary_ray(*camera, settings, target.x, target.y, s));
  RayTraversal traversal(context);
  std::vector<Ray> children;
  uint32_t seen = 0;
  while (!queue.empty()) {
    const Ray ray = queue.front();
    queue.pop_front();
    if (ray.type == target.type && seen++ == target.index) return ray;
    const HitRecord hit = trace_ray(traversal, ray);
    children.clear();
    spawn_secondary_rays(context.scene(), plan, settings, ray, 0, hit, children);
    queue.insert(queue.end(), children.begin(), children.end());
  }
  throw InputError("--trace-ray", "the frame has no " + what + " (it has " + std::to_string(seen) +
                                      " rays of that type there)");
}

bool RayProbe::is(const Ray& r) const {
  const Ray& t = target_;
  return r.pixel == t.pixel && r.type == t.type && r.sample == t.sample && r.bounce == t.bounce &&
         r.origin == t.origin && r.direction == t.direction && r.tmin == t.tmin && r.tmax == t.tmax;
}

void RayProbe::begin(uint64_t t_ps) {
  requests_.clear();
  accesses_.clear();
  step_ = ~0u;  // next_step() at the first step makes it step 0
  seen_ = true;
  start_ps_ = end_ps_ = t_ps;
}

namespace {
// The L1 an access goes through (0 node, 1 triangle, 2 texture): ray_engine.h's rule.
int l1_side(AccessKind kind) { return int(requester_of(kind)); }
}  // namespace

uint32_t RayProbe::add(const MemoryAccess* accesses, size_t count, const LineAccess* lines,
                       size_t line_count, uint32_t node_line_bytes, uint32_t triangle_line_bytes,
                       uint32_t texture_line_bytes, uint64_t issue_ps) {
  const uint32_t first = uint32_t(requests_.size());
  const uint32_t first_access = uint32_t(accesses_.size());
  accesses_.insert(accesses_.end(), accesses, accesses + count);
  for (size_t i = 0; i < line_count; ++i) {
    const LineAccess& l = lines[i];
    Request r;
    r.step = step_, r.kind = l.kind, r.write = l.write, r.line = l.line, r.bytes = l.bytes;
    r.issue_ps = r.done_ps = issue_ps;
    const int side = l1_side(l.kind);
    const uint64_t line_bytes = side == 0 ? node_line_bytes : side == 1 ? triangle_line_bytes : texture_line_bytes;
    // The accesses that fall in the line, as append_line_accesses merged them.
    for (size_t k = 0; k < count; ++k) {
      const MemoryAccess& a = accesses[k];
      const bool same_side = l1_side(a.kind) == side;
      if (same_side && a.write == l.write && a.address < l.line + line_bytes && a.address + a.bytes > l.line)
        r.carries.push_back(first_access + uint32_t(k));
    }
    requests_.push_back(std::move(r));
  }
  return first;
}

void RayProbe::served(uint32_t request, ServedBy by, uint64_t done_ps) {
  if (request >= requests_.size()) return;
  requests_[request].served = by;
  requests_[request].done_ps = done_ps;
}

void RayProbe::end(uint64_t t_ps, const RayCounters& counters) {
  end_ps_ = t_ps;
  counters_ = counters;
}

namespace {

// What a byte address in the image (or a stack spill area) holds, for the trace.
class RecordNames {
 public:
  RecordNames(const MemoryImage& image, const TraversalContext& context) : context_(context) {
    const Bvh& bvh = context.bvh();
    for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
      if (image.has_record(n)) nodes_[image.node_address(n)] = n;
      if (bvh.nodes[n].is_leaf() && image.indexed()) leaves_[image.prim_refs_address(n)] = n;
    }
    for (uint32_t s = 0; s < image.slot_count(); ++s) triangles_[image.slot_address(s)] = image.slot_triangle(s);
  }
  nlohmann::json of(const MemoryAccess& a) const {
    const auto id = [](const std::unordered_map<uint64_t, uint32_t>& m, uint64_t address) {
      auto it = m.find(address);
      return it == m.end() ? nlohmann::json(nullptr) : nlohmann::json(it->second);
    };
    switch (a.kind) {
      case AccessKind::Node: return {{"node", id(nodes_, a.address)}};
      case AccessKind::PrimRef: return {{"leaf", id(leaves_, a.address)}};
      case AccessKind::Triangle: return {{"triangle", id(triangles_, a.address)}};
      case AccessKind::Uv: return {{"uv_record", true}};
      case AccessKind::Texel: return {{"texel", true}};
      case AccessKind::Instance: return {{"instance_record", true}};
      case AccessKind::Stack: {
        const uint64_t base = context_.stack_area(0);
        const uint64_t entry = a.address >= base ? (a.address - base) / context_.config().stack_entry_bytes : 0;
        return {{"stack_entry", entry % TraversalContext::kStackAreaEntries}};
      }
    }
    return nullptr;
  }

 private:
  const TraversalContext& context_;
  std::unordered_map<uint64_t, uint32_t> nodes_, leaves_, triangles_;
};

std::string hex(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace

nlohmann::json ray_trace_json(const RayProbe& probe, const RayTarget& target, const MemoryImage& image,
                              const TraversalContext& context, double cycle_ps, uint64_t frame_start_ps,
                              bool timed) {
  using nlohmann::json;
  const Ray& ray = probe.target();
  const RecordNames names(image, context);
  const auto cycles = [&](uint64_t ps) { return std::llround(double(ps) / cycle_ps); };
  json requests = json::array();
  std::map<std::string, uint64_t> by_level;
  uint64_t latency_sum = 0, reads = 0;
  for (const RayProbe::Request& r : probe.requests()) {
    json records = json::array();
    for (uint32_t i : r.carries) {
      const MemoryAccess& a = probe.accesses()[i];
      json rec = names.of(a);
      rec["address"] = hex(a.address);
      rec["bytes"] = a.bytes;
      records.push_back(rec);
    }
    json j = {{"step", r.step},
              {"kind", access_kind_name(r.kind)},
              {"rw", r.write ? "W" : "R"},
              {"line", hex(r.line)},
              {"bytes", r.bytes},
              {"records", records},
              {"served", served_by_name(r.served)}};
    if (timed) {
      j["cycle"] = cycles(r.issue_ps - std::min(r.issue_ps, frame_start_ps));
      j["latency_cycles"] = cycles(r.done_ps - r.issue_ps);
      if (!r.write) latency_sum += r.done_ps - r.issue_ps, ++reads;
    }
    ++by_level[served_by_name(r.served)];
    requests.push_back(j);
  }
  const RayCounters& c = probe.counters();
  json totals = {{"requests", probe.requests().size()},
                 {"steps", probe.requests().empty() ? 0 : probe.requests().back().step + 1},
                 {"trv_ops", c.trv_ops},
                 {"ist_ops", c.ist_ops},
                 {"node_fetches", c.node_fetches},
                 {"prim_ref_fetches", c.prim_ref_fetches},
                 {"triangle_fetches", c.triangle_fetches},
                 {"fetch_bytes", c.bytes()},
                 {"stack_overflows", c.stack_overflows},
                 {"stack_refills", c.stack_refills},
                 {"served", by_level}};
  if (timed) {
    totals["cycles"] = cycles(probe.end_ps() - probe.start_ps());
    totals["start_cycle"] = cycles(probe.start_ps() - std::min(probe.start_ps(), frame_start_ps));
    totals["mean_read_latency_cycles"] = reads ? double(latency_sum) / double(reads) / cycle_ps : 0.0;
  }
  return {{"pixel", {target.x, target.y}},
          {"type", ray_type_name(target.type)},
          {"index", target.index},
          {"sample", ray.sample},
          {"bounce", ray.bounce},
          {"origin", {ray.origin.x, ray.origin.y, ray.origin.z}},
          {"direction", {ray.direction.x, ray.direction.y, ray.direction.z}},
          {"tmax", std::isfinite(ray.tmax) ? json(ray.tmax) : json("inf")},
          {"timed", timed},
          {"requests", requests},
          {"totals", totals}};
}

std::string ray_trace_text(const nlohmann::json& t) {
  std::ostringstream out;
  const bool timed = t.at("timed").get<bool>();
  const auto& totals = t.at("totals");
  char line[512];
  std::snprintf(line, sizeof line, "ray trace: %s ray %u of pixel %u,%u (sample %u, bounce %u)\n",
                t.at("type").get<std::string>().c_str(), t.at("index").get<unsigned>(),
                t.at("pixel")[0].get<unsigned>(), t.at("pixel")[1].get<unsigned>(),
                t.at("sample").get<unsigned>(), t.at("bounce").get<unsigned>());
  out << line;
  std::snprintf(line, sizeof line, "%5s %-8s %2s %12s %5s  %-18s %-32s", "step", "kind", "rw", "line",
                "bytes", "served", "records");
  out << line << (timed ? "  latency    cycle\n" : "\n");
  for (const auto& r : t.at("requests")) {
    std::string records;
    for (const auto& rec : r.at("records")) {
      for (auto it = rec.begin(); it != rec.end(); ++it) {
        if (it.key() == "address" || it.key() == "bytes") continue;
        records += (records.empty() ? "" : " ") + it.key() + " " + it.value().dump();
      }
    }
    if (records.size() > 32) records = records.substr(0, 29) + "...";
    std::snprintf(line, sizeof line, "%5u %-8s %2s %12s %5u  %-18s %-32s", r.at("step").get<unsigned>(),
                  r.at("kind").get<std::string>().c_str(), r.at("rw").get<std::string>().c_str(),
                  r.at("line").get<std::string>().c_str(), r.at("bytes").get<unsigned>(),
                  r.at("served").get<std::string>().c_str(), records.c_str());
    out << line;
    if (timed) {
      std::snprintf(line, sizeof line, "  %7lld %8lld", r.at("latency_cycles").get<long long>(),
                    r.at("cycle").get<long long>());
      out << line;
    }
    out << "\n";
  }
  out << "totals: " << totals.at("requests").get<uint64_t>() << " requests in " << totals.at("steps").get<uint64_t>()
      << " steps; " << totals.at("trv_ops").get<uint64_t>() << " TRV ops, " << totals.at("ist_ops").get<uint64_t>()
      << " IST ops; " << totals.at("node_fetches").get<uint64_t>() << " node, "
      << totals.at("prim_ref_fetches").get<uint64_t>() << " prim-ref, " << totals.at("triangle_fetches").get<uint64_t>()
      << " triangle fetches (" << totals.at("fetch_bytes").get<uint64_t>() << " bytes)";
  if (timed)
    out << "; " << totals.at("cycles").get<long long>() << " cycles from cycle "
        << totals.at("start_cycle").get<long long>() << ", mean read latency "
        << std::llround(totals.at("mean_read_latency_cycles").get<double>()) << " cycles";
  out << "\nserved:";
  for (auto it = totals.at("served").begin(); it != totals.at("served").end(); ++it)
    out << " " << it.key() << " " << it.value().get<uint64_t>() << ";";
  out << "\n";
  return out.str();
}

}  // namespace rtsim::sim
