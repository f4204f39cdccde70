// BVH node formats: the table, the half-float conversion, and the property the
// encoders exist for: every decoded child box contains its exact box, and is not
// much looser than the encoding's step (so a decoder returning the whole node's
// frame, or anything else lazy, fails).
#include <rtsim/builder/node_format.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <stdexcept>

namespace rtsim {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kHalfMax = 65504.0f;

Aabb box(vec3 lo, vec3 hi) {
  Aabb b;
  b.lo = lo;
  b.hi = hi;
  return b;
}

std::string str(const Aabb& b) {
  std::ostringstream s;
  s.precision(9);
  s << "[" << b.lo.x << " " << b.lo.y << " " << b.lo.z << " | " << b.hi.x << " " << b.hi.y << " " << b.hi.z << "]";
  return s.str();
}

// Boxes one record of `f` holds (OwnBoxFp32: only its own).
uint32_t slots(const NodeFormat& f) { return f.encoding == BoxEncoding::OwnBoxFp32 ? 1 : f.width; }

// Spacing of halves around |v| (v within the half range).
double half_spacing(double v) {
  v = std::fabs(v);
  if (v < std::ldexp(1.0, -14)) return std::ldexp(1.0, -24);
  return std::ldexp(1.0, int(std::floor(std::log2(v))) - 10);
}

// Spacing of floats around |v|.
double float_ulp(double v) {
  const float f = float(std::min(std::fabs(v), double(FLT_MAX)));
  return f == FLT_MAX ? std::ldexp(1.0, 104) : double(std::nextafter(f, kInf)) - double(f);
}

// Why `decoded` is not an acceptable encoding of `exact` (child of a node whose
// children span `frame`), or "" when it is: it must contain the exact box, and
// each plane must be as tight as the encoding allows, give or take one step.
std::string judge(const NodeFormat& f, const Aabb& exact, const Aabb& decoded, const Aabb& frame) {
  if (decoded.empty()) return "decoded empty";
  if (!decoded.contains(exact)) return "does not contain the exact box";
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const double v = side ? exact.hi[a] : exact.lo[a];
      const double d = side ? decoded.hi[a] : decoded.lo[a];
      std::string bad = "axis " + std::to_string(a) + (side ? " hi" : " lo") + " too loose";
      switch (f.encoding) {
        case BoxEncoding::Fp32:
        case BoxEncoding::OwnBoxFp32:
          if (d != v) return bad;
          break;
        case BoxEncoding::Fp16:
          if (v > kHalfMax) {  // past the range: the largest half below, or +inf above
            if (d != (side ? kInf : kHalfMax)) return bad;
          } else if (v < -kHalfMax) {
            if (d != (side ? -kHalfMax : -kInf)) return bad;
          } else if (std::fabs(d - v) > half_spacing(v)) {
            return bad;
          }
          break;
        case BoxEncoding::Quantized8: {
          // The encoder's scale is the smallest power of two with 255 steps
          // spanning the frame: below 2 * extent / 255 (or the smallest normal).
          const double extent = double(frame.hi[a]) - double(frame.lo[a]);
          const double step = std::max(2.0 * extent / 255.0, double(FLT_MIN));
          // In a frame wider than 255 * 2^120 the step q * 2^e overflows float
          // for large q (see node_format.cpp): hi planes there decode to +inf and
          // lo planes stop at the last finite step. Only containment holds.
          if (extent > 255.0 * std::ldexp(1.0, 120)) break;
          if (std::isinf(d)) return bad + " (inf)";
          if (std::fabs(d - v) > step + float_ulp(std::fabs(v) + step)) {
            return bad;
          }
          break;
        }
      }
    }
  return "";
}

// Encodes `boxes` as one record, decodes every slot and judges each one. Returns
// the number of failures (reported with `label`); `decoded` receives the
// decoded slots.
int check_node(const NodeFormat& f, const std::vector<Aabb>& boxes, const std::string& label,
               std::vector<Aabb>* decoded = nullptr) {
  const uint32_t count = uint32_t(boxes.size());
  constexpr uint32_t kGuard = 16;
  std::vector<uint8_t> record(f.record_bytes + kGuard, 0xa5);
  encode_child_boxes(f, boxes.data(), count, record.data());
  int failures = 0;
  for (uint32_t i = f.record_bytes; i < record.size(); ++i)
    if (record[i] != 0xa5) {
      ADD_FAILURE() << f.name << " " << label << ": encode wrote byte " << i << " past the record";
      return 1;
    }
  std::vector<Aabb> out(slots(f));
  decode_child_boxes(f, record.data(), slots(f), out.data());
  Aabb frame;
  for (const Aabb& b : boxes) frame.extend(b);
  for (uint32_t i = 0; i < out.size(); ++i) {
    if (i >= count) {
      if (!out[i].empty()) ADD_FAILURE() << f.name << " " << label << ": unused slot " << i << " decodes to " << str(out[i]);
      failures += !out[i].empty();
      continue;
    }
    const std::string why = judge(f, boxes[i], out[i], frame);
    if (!why.empty()) {
      ADD_FAILURE() << f.name << " " << label << " child " << i << "/" << count << ": " << why << "\n  exact   "
                    << str(boxes[i]) << "\n  decoded " << str(out[i]) << "\n  frame   " << str(frame);
      ++failures;
    }
  }
  if (decoded) *decoded = out;
  return failures;
}

// ---------------------------------------------------------------------------

TEST(NodeFormat, TableMatchesTheLayouts) {
  struct Row {
    const char* name;
    uint32_t width, bytes;
    BoxEncoding encoding;
    bool leaves_in_parent, contiguous;
    uint32_t max_leaf;
  };
  const Row expected[] = {
      {"bvh2-64", 2, 64, BoxEncoding::Fp32, true, false, 15},
      {"bvh2-32", 2, 32, BoxEncoding::OwnBoxFp32, false, false, 15},
      {"bvh4-128", 4, 128, BoxEncoding::Fp32, true, false, 4},
      {"bvh4-64h", 4, 64, BoxEncoding::Fp16, true, false, 4},
      {"bvh6-64q", 6, 64, BoxEncoding::Quantized8, true, true, 4},
      {"bvh8-80q", 8, 80, BoxEncoding::Quantized8, true, true, 3},
  };
  const std::vector<NodeFormat>& formats = node_formats();
  ASSERT_EQ(formats.size(), std::size(expected));
  for (size_t i = 0; i < formats.size(); ++i) {
    const NodeFormat& f = formats[i];
    const Row& r = expected[i];
    EXPECT_EQ(f.name, r.name);
    EXPECT_EQ(f.width, r.width) << r.name;
    EXPECT_EQ(f.record_bytes, r.bytes) << r.name;
    EXPECT_EQ(f.encoding, r.encoding) << r.name;
    EXPECT_EQ(f.leaves_in_parent, r.leaves_in_parent) << r.name;
    EXPECT_EQ(f.contiguous_children, r.contiguous) << r.name;
    EXPECT_EQ(f.max_leaf_triangles, r.max_leaf) << r.name;
    EXPECT_FALSE(f.summary.empty()) << r.name;
    EXPECT_FALSE(f.source.empty()) << r.name;
    if (i > 0) EXPECT_LE(formats[i - 1].width, f.width) << "narrowest first";
    EXPECT_EQ(&node_format(r.name), &f);
  }
  EXPECT_EQ(node_format_names(), "bvh2-64, bvh2-32, bvh4-128, bvh4-64h, bvh6-64q, bvh8-80q");
  EXPECT_EQ(node_format_names("|"), "bvh2-64|bvh2-32|bvh4-128|bvh4-64h|bvh6-64q|bvh8-80q");
}

TEST(NodeFormat, UnknownNameIsAnInputErrorListingTheKnownOnes) {
  for (const std::string field : {"memory.node_format", "--node-format"}) {
    try {
      if (field == "memory.node_format")
        node_format("nope");  // the default field
      else
        node_format("nope", field);
      FAIL() << "no exception";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(field + ": ", 0), 0u) << what;
      EXPECT_NE(what.find("'nope'"), std::string::npos) << what;
      for (const NodeFormat& f : node_formats()) EXPECT_NE(what.find(f.name), std::string::npos) << what;
    }
  }
}

TEST(NodeFormat, BadEncodeArgumentsAreProgrammingErrors) {
  const Aabb good = box(vec3(0), vec3(1));
  for (const NodeFormat& f : node_formats()) {
    std::vector<uint8_t> record(f.record_bytes);
    std::vector<Aabb> boxes(f.width + 1, good);
    EXPECT_THROW(encode_child_boxes(f, boxes.data(), 0, record.data()), std::invalid_argument) << f.name;
    EXPECT_THROW(encode_child_boxes(f, boxes.data(), slots(f) + 1, record.data()), std::invalid_argument) << f.name;
    EXPECT_NO_THROW(encode_child_boxes(f, boxes.data(), slots(f), record.data())) << f.name;
    for (const Aabb& bad : {Aabb{}, box(vec3(1), vec3(0)), box(vec3(0), vec3(1, kInf, 1)),
                            box(vec3(-kInf), vec3(1)), box(vec3(0, std::nanf(""), 0), vec3(1))}) {
      EXPECT_THROW(encode_child_boxes(f, &bad, 1, record.data()), std::invalid_argument) << f.name << " " << str(bad);
    }
    std::vector<Aabb> out(f.width + 1);
    EXPECT_THROW(decode_child_boxes(f, record.data(), slots(f) + 1, out.data()), std::invalid_argument) << f.name;
  }
  NodeFormat odd = node_format("bvh6-64q");
  odd.record_bytes = 48;  // no such layout: the encoder must not guess offsets
  std::vector<uint8_t> record(64);
  EXPECT_THROW(encode_child_boxes(odd, &good, 1, record.data()), std::invalid_argument);
}

// Every half survives the round trip bit for bit in both directions, and a
// float between two adjacent halves goes down to the lower and up to the upper.
TEST(NodeFormat, HalfConversionRoundsOutward) {
  for (uint32_t h = 0; h <= 0xffff; ++h) {
    const float f = half_to_float(uint16_t(h));
    if (std::isnan(f)) continue;
    ASSERT_EQ(float_to_half(f, false), h) << std::hex << h;
    ASSERT_EQ(float_to_half(f, true), h) << std::hex << h;
  }
  // Positive halves in order; negative ones mirror them.
  for (uint32_t h = 0; h < 0x7c00; ++h) {
    const float a = half_to_float(uint16_t(h)), b = half_to_float(uint16_t(h + 1));
    for (float x : {std::nextafter(a, kInf), 0.5f * (a + b), std::nextafter(b, 0.0f)}) {
      if (!(x > a && x < b)) continue;
      ASSERT_EQ(float_to_half(x, false), h) << x;
      ASSERT_EQ(float_to_half(x, true), h + 1) << x;
      ASSERT_EQ(float_to_half(-x, true), h | 0x8000) << -x;
      ASSERT_EQ(float_to_half(-x, false), (h + 1) | 0x8000) << -x;
    }
  }
  EXPECT_EQ(half_to_float(float_to_half(65505.0f, false)), kHalfMax);
  EXPECT_EQ(half_to_float(float_to_half(65505.0f, true)), kInf);
  EXPECT_EQ(half_to_float(float_to_half(-1e30f, true)), -kHalfMax);
  EXPECT_EQ(half_to_float(float_to_half(-1e30f, false)), -kInf);
  EXPECT_EQ(half_to_float(float_to_half(1e-40f, true)), std::ldexp(1.0f, -24));  // smallest subnormal half
  EXPECT_EQ(half_to_float(float_to_half(1e-40f, false)), 0.0f);
  EXPECT_EQ(half_to_float(float_to_half(kInf, false)), kInf);
  EXPECT_THROW(float_to_half(std::nanf(""), true), std::invalid_argument);
}

// The judge must reject what a lazy or wrong decoder would return, otherwise
// the property tests below prove nothing.
TEST(NodeFormat, JudgeRejectsLooseAndShrunkBoxes) {
  const Aabb child = box(vec3(1, 2, 3), vec3(1.5f, 2.25f, 3.125f));
  const Aabb frame = box(vec3(-10), vec3(10));
  for (const NodeFormat& f : node_formats()) {
    EXPECT_EQ(judge(f, child, child, frame), "") << f.name;
    EXPECT_NE(judge(f, child, frame, frame), "") << f.name << ": the frame is not a child box";
    Aabb shrunk = child;
    shrunk.hi.y = std::nextafter(child.hi.y, 0.0f);
    EXPECT_NE(judge(f, child, shrunk, frame), "") << f.name;
    Aabb loose = child;
    loose.lo.z -= 1.0f;  // 1.0 > 2 * 20 / 255 + ulp: too loose even for the quantized step
    EXPECT_NE(judge(f, child, loose, frame), "") << f.name;
    EXPECT_NE(judge(f, child, Aabb{}, frame), "") << f.name;
  }
}

// Seeded random nodes: child counts 1..width, coordinates around offsets and
// with sizes from 1e-3 to 1e6 (mixed freely, so small boxes far from the origin
// hit the float precision limit too). Prints the surface-area looseness.
TEST(NodeFormat, RandomNodesDecodeConservativelyAndTightly) {
  const double magnitudes[] = {1e-3, 1e-2, 1.0, 1e2, 1e4, 1e6};
  for (const NodeFormat& f : node_formats()) {
    std::mt19937 rng(0x5eed'f0a7);
    std::uniform_int_distribution<uint32_t> count_of(1, slots(f));
    std::uniform_int_distribution<int> magnitude_of(0, int(std::size(magnitudes)) - 1);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    // Surface area decoded / exact, over all children with a positive area and
    // over the "shapely" ones (no extent below 1% of the frame's extent or of the
    // box's own largest coordinate, so neither the 8-bit step nor the float or
    // half spacing dwarfs it);
    // children whose decoded area is infinite (Fp16 past 65504) are counted apart.
    std::vector<double> ratios, shapely;
    size_t unbounded = 0;
    int failures = 0;
    for (int node = 0; node < 3000 && failures < 5; ++node) {
      const double offset = magnitudes[magnitude_of(rng)] * (node % 7 == 0 ? 0.0 : 4.0);
      const double size = magnitudes[magnitude_of(rng)];
      const vec3 centre(offset * unit(rng), offset * unit(rng), offset * unit(rng));
      std::vector<Aabb> boxes(count_of(rng));
      for (Aabb& b : boxes)
        for (int a = 0; a < 3; ++a) {
          const double lo = centre[a] + size * unit(rng);
          const double u = 0.5 * (unit(rng) + 1.0);
          const double extent = node % 11 == 0 ? 0.0 : size * u * u * u;  // many thin, some flat
          b.lo[a] = float(lo);
          b.hi[a] = std::max(b.lo[a], float(lo + extent));
        }
      std::vector<Aabb> decoded;
      failures += check_node(f, boxes, "random node " + std::to_string(node), &decoded);
      Aabb frame;
      for (const Aabb& b : boxes) frame.extend(b);
      for (size_t i = 0; i < boxes.size(); ++i) {
        if (!(boxes[i].area() > 0)) continue;
        const double ratio = double(decoded[i].area()) / double(boxes[i].area());
        if (!std::isfinite(ratio)) {
          ++unbounded;
          continue;
        }
        ratios.push_back(ratio);
        const vec3 e = boxes[i].extent();
        const vec3 floor_extent = 0.01f * glm::max(frame.extent(), glm::max(glm::abs(boxes[i].lo), glm::abs(boxes[i].hi)));
        if (glm::all(glm::greaterThanEqual(e, floor_extent))) shapely.push_back(ratio);
      }
    }
    ASSERT_FALSE(ratios.empty()) << f.name;
    ASSERT_FALSE(shapely.empty()) << f.name;
    const auto summary = [](std::vector<double>& r) {
      std::sort(r.begin(), r.end());
      double sum = 0;
      for (double x : r) sum += x;
      char line[160];
      std::snprintf(line, sizeof line, "n %5zu mean %8.4g median %.4f p99 %8.4g max %8.4g", r.size(),
                    sum / double(r.size()), r[r.size() / 2], r[r.size() * 99 / 100], r.back());
      return std::string(line);
    };
    std::printf("  %-9s area decoded/exact  all: %s\n  %-9s          shapely: %s\n"
                "  %-9s          infinite decoded area: %zu\n",
                f.name.c_str(), summary(ratios).c_str(), "", summary(shapely).c_str(), "", unbounded);
  }
}

// Hand-picked nodes where encoders usually break.
std::vector<std::pair<std::string, std::vector<Aabb>>> hard_nodes(uint32_t width) {
  const vec3 p(1, 2, 3), q(-1, 5, 0.25f);
  const float one_up = std::nextafter(1.0f, 2.0f);
  std::vector<std::pair<std::string, std::vector<Aabb>>> nodes = {
      {"flat in x", {box({3, 0, 0}, {3, 1, 1}), box({3, -2, 0.5f}, {3, 4, 2}), box({3, 7, -1}, {3, 8, 0})}},
      {"flat in all axes", {box(p, p), box(q, q), box(p, p)}},
      {"a point", {box(p, p)}},
      {"the origin", {box(vec3(0), vec3(0))}},
      {"1e18", {box(vec3(1e18f), vec3(1.001e18f)), box(vec3(-1e18f), vec3(-0.5e18f)), box(vec3(0), vec3(1e18f))}},
      {"1e18 and a unit box", {box(vec3(1e18f), vec3(1e18f)), box(vec3(0), vec3(1))}},
      {"near FLT_MAX", {box(vec3(3e38f), vec3(FLT_MAX)), box(vec3(-FLT_MAX), vec3(-3e38f))}},
      {"all of float", {box(vec3(-FLT_MAX), vec3(FLT_MAX)), box(vec3(0), vec3(1)), box(vec3(-2), vec3(FLT_MAX))}},
      {"subnormal size at 0", {box(vec3(0), vec3(1e-40f)), box(vec3(2e-45f), vec3(3e-40f))}},
      {"subnormal size at 1", {box(vec3(1), vec3(1 + 1e-40f)), box(vec3(1), vec3(one_up))}},
      {"subnormal around 0", {box(vec3(-1e-40f), vec3(1e-40f)), box(vec3(1e-45f), vec3(2e-45f))}},
      {"tiny normals", {box(vec3(1e-37f), vec3(2e-37f)), box(vec3(FLT_MIN), vec3(2 * FLT_MIN))}},
      {"negative", {box({-1e5f, -2e3f, -7}, {-1e3f, -1e3f, -1}), box({-5e4f, -1.5e3f, -6}, {-4e4f, -1e3f, -5.5f})}},
      {"spanning the node", {box(vec3(-10), vec3(10)), box(vec3(0), vec3(0.001f)), box(vec3(9.99f), vec3(10))}},
      {"identical", std::vector<Aabb>(width, box({0.1f, 0.2f, 0.3f}, {0.7f, 0.8f, 0.9f}))},
      {"identical points", std::vector<Aabb>(width, box(q, q))},
      {"one child", {box({0.1f, -3, 5}, {2, -1, 5.5f})}},
      {"mixed magnitudes", {box(vec3(0), vec3(1e-3f)), box(vec3(1e6f), vec3(1e6f + 1))}},
      // v - origin = 2^40 +- 2^-20 rounds to 2^40 even in double: the first guess
      // of both planes lands on the wrong side and must be stepped outward.
      {"tiny child, distant origin",
       {box(vec3(-0x1p40f), vec3(0x1p39f)), box(vec3(0), vec3(0x1p-20f)), box(vec3(-0x1p-20f), vec3(0))}},
      {"small, far away", {box(vec3(1e6f), vec3(1e6f + 0.0625f)), box(vec3(1e6f + 0.125f), vec3(1e6f + 0.25f))}},
      {"half range edge", {box(vec3(-65504), vec3(65504)), box(vec3(65504), vec3(65520)), box(vec3(-7e4f), vec3(-6e4f))}},
  };
  for (auto& node : nodes)
    if (node.second.size() > width) node.second.resize(width);
  return nodes;
}

TEST(NodeFormat, HardNodesDecodeConservatively) {
  for (const NodeFormat& f : node_formats()) {
    for (const auto& [label, boxes] : hard_nodes(f.width)) {
      if (f.encoding == BoxEncoding::OwnBoxFp32) {
        for (const Aabb& b : boxes) check_node(f, {b}, label);
      } else {
        check_node(f, boxes, label);
      }
    }
  }
}

// Decoding fewer children than the record holds, and an exact-fit quantized
// frame: children at the frame's ends decode to the frame's ends exactly.
TEST(NodeFormat, PartialDecodeAndFrameEnds) {
  const std::vector<Aabb> boxes = {box(vec3(-3), vec3(-1)), box(vec3(2), vec3(5)), box(vec3(0), vec3(1))};
  for (const NodeFormat& f : node_formats()) {
    if (slots(f) < boxes.size()) continue;
    std::vector<uint8_t> record(f.record_bytes);
    encode_child_boxes(f, boxes.data(), uint32_t(boxes.size()), record.data());
    Aabb first[2];
    decode_child_boxes(f, record.data(), 2, first);
    EXPECT_EQ(first[0].lo, vec3(-3)) << f.name;  // frame.lo is the origin: exact
    EXPECT_EQ(first[1].hi, vec3(5)) << f.name;   // (5 - -3) / 2^-4 = 128 steps: exact in every format
    EXPECT_TRUE(first[0].contains(boxes[0]) && first[1].contains(boxes[1])) << f.name;
  }
}

}  // namespace
}  // namespace rtsim
