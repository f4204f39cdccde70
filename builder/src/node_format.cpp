// BVH node formats: the table, the record layouts and the conservative
// encoders/decoders of child boxes. Every encoder checks its result with the
// decoder's own arithmetic, so containment never rests on a rounding argument.
#include <rtsim/builder/node_format.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace rtsim {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// ---------------------------------------------------------------------------
// Record layouts: byte offsets of every field. Only the box fields (and the
// quantization frame) are written here; the other offsets are listed so that
// the static_asserts below check each layout adds up to its record size.

constexpr uint32_t kFp32BoxBytes = 6 * 4;  // lo.xyz, hi.xyz as fp32
constexpr uint32_t kFp16BoxBytes = 6 * 2;  // lo.xyz, hi.xyz as binary16

namespace bvh2_64 {  // rtsim's binary node
constexpr uint32_t kBoxes = 0;   // 2 boxes
constexpr uint32_t kLinks = 48;  // 2 x 8 B child links
constexpr uint32_t kEnd = kLinks + 2 * 8;
static_assert(kBoxes + 2 * kFp32BoxBytes == kLinks && kEnd == 64, "bvh2-64 layout");
}  // namespace bvh2_64

namespace bvh2_32 {  // rtsim's single-box node
constexpr uint32_t kBox = 0;
constexpr uint32_t kLink = 24;   // 4 B first child / first triangle
constexpr uint32_t kCount = 28;  // 4 B triangle count (0: inner node)
constexpr uint32_t kEnd = kCount + 4;
static_assert(kBox + kFp32BoxBytes == kLink && kEnd == 32, "bvh2-32 layout");
}  // namespace bvh2_32

namespace bvh4_128 {  // AMD box32
constexpr uint32_t kChildPointers = 0;  // 4 x 4 B
constexpr uint32_t kBoxes = 16;         // 4 boxes
constexpr uint32_t kReserved = kBoxes + 4 * kFp32BoxBytes;
constexpr uint32_t kEnd = kReserved + 16;
static_assert(kChildPointers + 4 * 4 == kBoxes && kReserved == 112 && kEnd == 128, "bvh4-128 layout");
}  // namespace bvh4_128

namespace bvh4_64h {  // AMD box16
constexpr uint32_t kChildPointers = 0;  // 4 x 4 B
constexpr uint32_t kBoxes = 16;         // 4 boxes
constexpr uint32_t kEnd = kBoxes + 4 * kFp16BoxBytes;
static_assert(kChildPointers + 4 * 4 == kBoxes && kEnd == 64, "bvh4-64h layout");
}  // namespace bvh4_64h

namespace bvh6_64q {  // Intel-class quantized 6-wide node
constexpr uint32_t kOrigin = 0;        // 3 x fp32
constexpr uint32_t kChildOffset = 12;  // 4 B
constexpr uint32_t kNodeType = 16;     // 1 B
constexpr uint32_t kReserved = 17;     // 1 B
constexpr uint32_t kExponents = 18;    // 3 x 1 B
constexpr uint32_t kNodeMask = 21;     // 1 B
constexpr uint32_t kChildData = 22;    // 6 x 1 B
constexpr uint32_t kLowerX = 28, kUpperX = 34, kLowerY = 40, kUpperY = 46, kLowerZ = 52,
                   kUpperZ = 58;  // 6 x 1 B each
constexpr uint32_t kEnd = kUpperZ + 6;
static_assert(kOrigin + 12 == kChildOffset && kChildOffset + 4 == kNodeType &&
                  kNodeType + 1 == kReserved && kReserved + 1 == kExponents &&
                  kExponents + 3 == kNodeMask && kNodeMask + 1 == kChildData &&
                  kChildData + 6 == kLowerX && kLowerX + 6 == kUpperX && kUpperX + 6 == kLowerY &&
                  kLowerY + 6 == kUpperY && kUpperY + 6 == kLowerZ && kLowerZ + 6 == kUpperZ &&
                  kEnd == 64,
              "bvh6-64q layout");
}  // namespace bvh6_64q

namespace bvh8_80q {  // Ylitie, Karras, Laine 2017
constexpr uint32_t kOrigin = 0;         // 3 x fp32
constexpr uint32_t kExponents = 12;     // 3 x 1 B
constexpr uint32_t kImask = 15;         // 1 B: which children are inner nodes
constexpr uint32_t kChildBase = 16;     // 4 B
constexpr uint32_t kTriangleBase = 20;  // 4 B
constexpr uint32_t kMeta = 24;          // 8 x 1 B
constexpr uint32_t kLoX = 32, kLoY = 40, kLoZ = 48, kHiX = 56, kHiY = 64,
                   kHiZ = 72;  // 8 x 1 B each
constexpr uint32_t kEnd = kHiZ + 8;
static_assert(kOrigin + 12 == kExponents && kExponents + 3 == kImask && kImask + 1 == kChildBase &&
                  kChildBase + 4 == kTriangleBase && kTriangleBase + 4 == kMeta &&
                  kMeta + 8 == kLoX && kLoX + 8 == kLoY && kLoY + 8 == kLoZ && kLoZ + 8 == kHiX &&
                  kHiX + 8 == kHiY && kHiY + 8 == kHiZ && kEnd == 80,
              "bvh8-80q layout");
}  // namespace bvh8_80q

// Where a format's box fields sit: float boxes at `boxes` + i * stride, or a
// quantized frame with one plane array (width bytes) per axis and side.
struct BoxLayout {
  uint32_t boxes = 0, stride = 0;           // Fp32, Fp16, OwnBoxFp32
  uint32_t origin = 0, exponents = 0;       // Quantized8
  uint32_t lo_planes[3] = {}, hi_planes[3] = {};
};

// The layout is chosen from encoding, width and size rather than the name, so
// the per-node decode costs a few integer compares.
BoxLayout layout_of(const NodeFormat& f) {
  BoxLayout l;
  const auto is = [&](BoxEncoding e, uint32_t width, uint32_t bytes) {
    return f.encoding == e && f.width == width && f.record_bytes == bytes;
  };
  if (is(BoxEncoding::Fp32, 2, 64)) {
    l.boxes = bvh2_64::kBoxes, l.stride = kFp32BoxBytes;
  } else if (is(BoxEncoding::OwnBoxFp32, 2, 32)) {
    l.boxes = bvh2_32::kBox, l.stride = kFp32BoxBytes;
  } else if (is(BoxEncoding::Fp32, 4, 128)) {
    l.boxes = bvh4_128::kBoxes, l.stride = kFp32BoxBytes;
  } else if (is(BoxEncoding::Fp16, 4, 64)) {
    l.boxes = bvh4_64h::kBoxes, l.stride = kFp16BoxBytes;
  } else if (is(BoxEncoding::Quantized8, 6, 64)) {
    using namespace bvh6_64q;
    l.origin = kOrigin, l.exponents = kExponents;
    l.lo_planes[0] = kLowerX, l.lo_planes[1] = kLowerY, l.lo_planes[2] = kLowerZ;
    l.hi_planes[0] = kUpperX, l.hi_planes[1] = kUpperY, l.hi_planes[2] = kUpperZ;
  } else if (is(BoxEncoding::Quantized8, 8, 80)) {
    using namespace bvh8_80q;
    l.origin = kOrigin, l.exponents = kExponents;
    l.lo_planes[0] = kLoX, l.lo_planes[1] = kLoY, l.lo_planes[2] = kLoZ;
    l.hi_planes[0] = kHiX, l.hi_planes[1] = kHiY, l.hi_planes[2] = kHiZ;
  } else {
    throw std::invalid_argument("node format '" + f.name + "': no record layout for its encoding/width/size");
  }
  return l;
}

// ---------------------------------------------------------------------------
// Raw field access (records are byte arrays; memcpy keeps it alignment-safe).

float load_f32(const uint8_t* p) {
  float v;
  std::memcpy(&v, p, 4);
  return v;
}
void store_f32(uint8_t* p, float v) { std::memcpy(p, &v, 4); }
uint16_t load_u16(const uint8_t* p) {
  uint16_t v;
  std::memcpy(&v, p, 2);
  return v;
}
void store_u16(uint8_t* p, uint16_t v) { std::memcpy(p, &v, 2); }

// ---------------------------------------------------------------------------
// Quantized8: plane = origin + 2^e * q, q in 0..255, origin = the children's
// union's lo, e stored as e + 127 in one byte (the fp32 exponent bias, as in
// Ylitie et al.). e is kept in [-126, 127] so the scale is a normal float: an
// axis whose extent is subnormal-small just gets the coarser 2^-126, and a flat
// axis (extent 0) takes e = -126 with every plane q = 0, the origin exactly.

constexpr int kExpBias = 127;
constexpr int kMinExp = -126;
constexpr int kMaxExp = 127;
constexpr uint32_t kMaxQ = 255;

// The one decode formula; the encoder verifies every plane with it. The project
// builds with -ffp-contract=off, so this is a float multiply then a float add
// everywhere. scale * q is exact unless it overflows, which only happens for
// e >= 121, i.e. frames wider than 255 * 2^120 (~3.4e38): there upper planes
// past the overflow decode to +inf and lower planes stop at the last finite
// step (conservative, and unavoidable with this arithmetic; 1e18-sized scenes
// are far from it).
inline float decode_plane(float origin, float scale, uint32_t q) {
  return origin + scale * float(q);
}

// Smallest e whose top plane (q = 255) reaches `hi` from `origin`.
int choose_exponent(float origin, float hi) {
  const double extent = double(hi) - double(origin);  // may round for wide ranges; verified below
  int e = kMinExp;
  if (extent > 0) {
    int exp2 = 0;
    const double m = std::frexp(extent / kMaxQ, &exp2);  // extent / 255 = m * 2^exp2, m in [0.5, 1)
    e = m == 0.5 ? exp2 - 1 : exp2;                       // 2^e >= extent / 255
    e = std::max(kMinExp, std::min(kMaxExp, e));
  }
  // Should the float decode of origin + 2^e * 255 fall short of hi (extent
  // above may have rounded), widen.
  while (e < kMaxExp && decode_plane(origin, std::ldexp(1.0f, e), kMaxQ) < hi) ++e;
  return e;
}

// Lower plane: floor of the exact quotient, then stepped down while the decode
// arithmetic rounds it above v (q = 0 decodes to the origin, which is <= v).
// Upper plane: ceil, stepped up while it decodes below v (q = 255 reaches the
// frame's top by choose_exponent). Both start from the same quotient and only
// move outward, so a real child always has lo q <= hi q and lo > hi is free to
// mark an unused slot.
uint32_t quantize_lo(float origin, float scale, int e, float v) {
  const double steps = std::floor(std::ldexp(double(v) - double(origin), -e));
  uint32_t q = uint32_t(std::max(0.0, std::min(double(kMaxQ), steps)));
  while (q > 0 && decode_plane(origin, scale, q) > v) --q;
  return q;
}

uint32_t quantize_hi(float origin, float scale, int e, float v) {
  const double steps = std::ceil(std::ldexp(double(v) - double(origin), -e));
  uint32_t q = uint32_t(std::max(0.0, std::min(double(kMaxQ), steps)));
  while (q < kMaxQ && decode_plane(origin, scale, q) < v) ++q;
  if (decode_plane(origin, scale, q) < v) throw std::logic_error("quantize_hi: frame does not reach the box");
  return q;
}

void encode_quantized(const BoxLayout& l, uint32_t width, const Aabb* boxes, uint32_t count,
                      uint8_t* record) {
  Aabb frame;
  for (uint32_t i = 0; i < count; ++i) frame.extend(boxes[i]);
  for (int a = 0; a < 3; ++a) {
    const float origin = frame.lo[a];
    const int e = choose_exponent(origin, frame.hi[a]);
    const float scale = std::ldexp(1.0f, e);
    store_f32(record + l.origin + 4 * a, origin);
    record[l.exponents + a] = uint8_t(e + kExpBias);
    for (uint32_t i = 0; i < width; ++i) {
      // An unused slot gets lo = 255 > hi = 0, which no real child can have
      // (its lo plane never passes its hi plane).
      const bool used = i < count;
      record[l.lo_planes[a] + i] = uint8_t(used ? quantize_lo(origin, scale, e, boxes[i].lo[a]) : kMaxQ);
      record[l.hi_planes[a] + i] = uint8_t(used ? quantize_hi(origin, scale, e, boxes[i].hi[a]) : 0);
    }
  }
}

void decode_quantized(const BoxLayout& l, const uint8_t* record, uint32_t count, Aabb* out) {
  float origin[3], scale[3];
  for (int a = 0; a < 3; ++a) {
    origin[a] = load_f32(record + l.origin + 4 * a);
    scale[a] = std::ldexp(1.0f, int(record[l.exponents + a]) - kExpBias);
  }
  for (uint32_t i = 0; i < count; ++i) {
    Aabb box;
    bool used = true;
    for (int a = 0; a < 3; ++a) used = used && record[l.lo_planes[a] + i] <= record[l.hi_planes[a] + i];
    if (used)
      for (int a = 0; a < 3; ++a) {
        box.lo[a] = decode_plane(origin[a], scale[a], record[l.lo_planes[a] + i]);
        box.hi[a] = decode_plane(origin[a], scale[a], record[l.hi_planes[a] + i]);
      }
    out[i] = box;
  }
}

// ---------------------------------------------------------------------------
// Float boxes (Fp32, OwnBoxFp32, Fp16). An unused slot stores lo = +inf,
// hi = -inf: the empty Aabb, representable in both widths.

void encode_float_boxes(const BoxLayout& l, BoxEncoding encoding, uint32_t width, const Aabb* boxes,
                        uint32_t count, uint8_t* record) {
  const Aabb empty;
  for (uint32_t i = 0; i < width; ++i) {
    const Aabb& box = i < count ? boxes[i] : empty;
    uint8_t* p = record + l.boxes + i * l.stride;
    for (int a = 0; a < 3; ++a) {
      if (encoding == BoxEncoding::Fp16) {
        store_u16(p + 2 * a, float_to_half(box.lo[a], false));
        store_u16(p + 2 * (3 + a), float_to_half(box.hi[a], true));
      } else {
        store_f32(p + 4 * a, box.lo[a]);
        store_f32(p + 4 * (3 + a), box.hi[a]);
      }
    }
  }
}

void decode_float_boxes(const BoxLayout& l, BoxEncoding encoding, const uint8_t* record, uint32_t count,
                        Aabb* out) {
  for (uint32_t i = 0; i < count; ++i) {
    const uint8_t* p = record + l.boxes + i * l.stride;
    Aabb box;
    for (int a = 0; a < 3; ++a) {
      if (encoding == BoxEncoding::Fp16) {
        box.lo[a] = half_to_float(load_u16(p + 2 * a));
        box.hi[a] = half_to_float(load_u16(p + 2 * (3 + a)));
      } else {
        box.lo[a] = load_f32(p + 4 * a);
        box.hi[a] = load_f32(p + 4 * (3 + a));
      }
    }
    out[i] = box;
  }
}

std::vector<NodeFormat> make_formats() {
  const auto format = [](std::string name, uint32_t width, uint32_t bytes, BoxEncoding encoding,
                         bool leaves_in_parent, bool contiguous, uint32_t max_leaf, std::string summary,
                         std::string source) {
    NodeFormat f;
    f.name = std::move(name);
    f.width = width;
    f.record_bytes = bytes;
    f.encoding = encoding;
    f.leaves_in_parent = leaves_in_parent;
    f.contiguous_children = contiguous;
    f.max_leaf_triangles = max_leaf;
    f.summary = std::move(summary);
    f.source = std::move(source);
    return f;
  };
  return {
      format("bvh2-64", 2, 64, BoxEncoding::Fp32, true, false, 15,
             "binary node, both child boxes in fp32 and two 8-byte links (rtsim's default)",
             "rtsim's own binary node (the offsets in node_format.h): child boxes at bytes 0 and "
             "24 (lo xyz, hi xyz, fp32), 8-byte child links at 48 and 56; the 15-triangle leaf limit is "
             "rtsim's choice of a 4-bit count"),
      format("bvh2-32", 2, 32, BoxEncoding::OwnBoxFp32, false, false, 15,
             "binary tree, one record per node holding its own fp32 box, a link and a count",
             "rtsim's own single-box node (the offsets in node_format.h): own box at byte 0 "
             "(24 B fp32), 4-byte link at 24, 4-byte triangle count at 28; the 15-triangle leaf limit "
             "is rtsim's choice"),
      format("bvh4-128", 4, 128, BoxEncoding::Fp32, true, false, 4,
             "4-wide node, four fp32 child boxes and four 4-byte child pointers (AMD box32 class)",
             "AMD RDNA ray-tracing 'box32' node class (RDNA ISA guides; RRA and Mesa radv describe the same "
             "record): 4 x 4 B child pointers at byte 0, 4 x 24 B fp32 boxes at 16, 16 B reserved; "
             "the 4-triangle leaf limit is rtsim's choice (its default leaf size), not a published field"),
      format("bvh4-64h", 4, 64, BoxEncoding::Fp16, true, false, 4,
             "4-wide node, four half-float child boxes rounded outward (AMD box16 class)",
             "AMD RDNA ray-tracing 'box16' node class (RDNA ISA guides; RRA and Mesa radv describe the same "
             "record): 4 x 4 B child pointers at byte 0, 4 x 12 B boxes of six IEEE halves at 16; "
             "outward rounding is rtsim's conservative conversion; the 4-triangle leaf limit is rtsim's "
             "choice (its default leaf size), not a published field"),
      format("bvh6-64q", 6, 64, BoxEncoding::Quantized8, true, true, 4,
             "6-wide quantized node: fp32 origin, per-axis power-of-two scale, 8-bit child planes (Intel class)",
             "Intel Xe ray-tracing class 6-wide internal node (as Embree's public QBVH6 node describes it): "
             "fp32 origin 12 B, child offset 4 B, node type 1 B, reserved 1 B, 3 exponent bytes, node mask "
             "1 B, 6 child-data bytes, 6 x 6 plane bytes (lower/upper per axis) = 64 B; the exponent byte "
             "uses rtsim's biased (fp32-style) encoding and the 4-triangle leaf limit is rtsim's choice "
             "(its default leaf size), not a published field"),
      format("bvh8-80q", 8, 80, BoxEncoding::Quantized8, true, true, 3,
             "8-wide compressed node: fp32 origin, per-axis power-of-two scale, 8-bit child planes (CWBVH)",
             "Ylitie, Karras, Laine, 'Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide "
             "BVHs', HPG 2017: origin 3 x fp32, 3 biased exponent bytes, imask 1 B, child node base index "
             "4 B, triangle base index 4 B, 8 meta bytes, 8 x 6 quantized plane bytes = 80 B; leaves of up "
             "to 3 triangles as in the paper"),
  };
}

}  // namespace

// ---------------------------------------------------------------------------

uint16_t float_to_half(float x, bool round_up) {
  uint32_t bits;
  std::memcpy(&bits, &x, 4);
  const uint16_t sign = uint16_t((bits >> 16) & 0x8000u);
  const uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude > 0x7f800000u) throw std::invalid_argument("float_to_half: NaN");

  // First truncate the magnitude (round toward zero), noting whether that lost
  // anything; then step one half away from zero when the requested direction
  // points away from zero on this side.
  uint16_t half;
  bool inexact;
  const int exponent = int(magnitude >> 23) - 127;  // -127 for float zero/subnormals
  if (magnitude == 0x7f800000u) {
    half = 0x7c00, inexact = false;  // inf stays inf
  } else if (exponent > 15) {
    half = 0x7bff, inexact = true;  // past 65504: truncates to the largest finite half
  } else if (exponent >= -14) {     // a normal half: keep the top 10 mantissa bits
    const uint32_t mantissa = magnitude & 0x7fffffu;
    half = uint16_t(uint32_t(exponent + 15) << 10 | mantissa >> 13);
    inexact = (mantissa & 0x1fffu) != 0;
  } else {  // a subnormal half (or zero): a multiple of 2^-24
    const double scaled = std::ldexp(double(std::fabs(x)), 24);  // exact
    const double whole = std::floor(scaled);
    half = uint16_t(whole);
    inexact = whole != scaled;
  }
  const bool negative = sign != 0;
  // The next magnitude is the next bit pattern, including 0x7bff -> inf.
  if (inexact && round_up != negative) ++half;
  return uint16_t(sign | half);
}

float half_to_float(uint16_t h) {
  const int exponent = (h >> 10) & 0x1f;
  const int mantissa = h & 0x3ff;
  float magnitude;
  if (exponent == 0)
    magnitude = std::ldexp(float(mantissa), -24);
  else if (exponent == 31)
    magnitude = mantissa == 0 ? kInf : std::numeric_limits<float>::quiet_NaN();
  else
    magnitude = std::ldexp(float(mantissa | 0x400), exponent - 25);
  return (h & 0x8000) ? -magnitude : magnitude;
}

const std::vector<NodeFormat>& node_formats() {
  static const std::vector<NodeFormat> formats = make_formats();
  return formats;
}

std::string node_format_names(const char* separator) {
  std::string names;
  for (const NodeFormat& f : node_formats()) names += (names.empty() ? "" : separator) + f.name;
  return names;
}

const NodeFormat& node_format(const std::string& name, const std::string& field) {
  for (const NodeFormat& f : node_formats())
    if (f.name == name) return f;
  throw InputError(field, "unknown node format '" + name + "' (known: " + node_format_names() + ")");
}

void encode_child_boxes(const NodeFormat& format, const Aabb* boxes, uint32_t count, uint8_t* record) {
  const BoxLayout layout = layout_of(format);
  const uint32_t most = format.encoding == BoxEncoding::OwnBoxFp32 ? 1 : format.width;
  if (count == 0 || count > most)
    throw std::invalid_argument("encode_child_boxes: " + format.name + " takes 1.." + std::to_string(most) +
                                " boxes, got " + std::to_string(count));
  for (uint32_t i = 0; i < count; ++i)
    if (boxes[i].empty() || !is_finite(boxes[i].lo) || !is_finite(boxes[i].hi))
      throw std::invalid_argument("encode_child_boxes: box " + std::to_string(i) + " is empty or not finite");

  std::memset(record, 0, format.record_bytes);
  if (format.encoding == BoxEncoding::Quantized8)
    encode_quantized(layout, format.width, boxes, count, record);
  else
    encode_float_boxes(layout, format.encoding, most, boxes, count, record);
}

void decode_child_boxes(const NodeFormat& format, const uint8_t* record, uint32_t count, Aabb* out) {
  const BoxLayout layout = layout_of(format);
  const uint32_t most = format.encoding == BoxEncoding::OwnBoxFp32 ? 1 : format.width;
  if (count > most)
    throw std::invalid_argument("decode_child_boxes: " + format.name + " holds " + std::to_string(most) +
                                " boxes, asked for " + std::to_string(count));
  if (format.encoding == BoxEncoding::Quantized8)
    decode_quantized(layout, record, count, out);
  else
    decode_float_boxes(layout, format.encoding, record, count, out);
}

}  // namespace rtsim
