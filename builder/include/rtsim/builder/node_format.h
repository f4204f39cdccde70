#pragma once
// BVH node formats: how one node record is laid out in the accelerator's memory.
// One description per format (children per record, bytes, where leaf information
// sits, how child boxes are encoded), and the encoder/decoder of its child boxes.
//
// The memory image encodes every record with encode_child_boxes and the
// traversal tests the boxes decode_child_boxes gives back, so quantization shows
// in the operation counts as it would in hardware. Every encoding is
// conservative: each decoded box contains the exact box it encodes.
#include <rtsim/workloads/geometry.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

enum class BoxEncoding : uint8_t {
  OwnBoxFp32,   // the record holds its own node's box (fp32), not its children's
  Fp32,         // child boxes as 6 floats each
  Fp16,         // child boxes as 6 IEEE half floats each, rounded outward
  Quantized8,   // per-node frame (fp32 origin, power-of-two scale per axis) and
                // 8-bit child planes: lo = origin + floor(..) * scale, hi = ceil
};

struct NodeFormat {
  std::string name;              // "bvh2-64", "bvh4-128", ...
  uint32_t width = 2;            // most children per record
  uint32_t record_bytes = 64;
  BoxEncoding encoding = BoxEncoding::Fp32;
  // A leaf child's triangle range sits in its parent's record, so leaves take no
  // record of their own (false only for OwnBoxFp32: every node has a record).
  bool leaves_in_parent = true;
  // One child base pointer per record: the records of a node's inner children
  // must be adjacent in memory (compressed formats); otherwise each child slot
  // holds its own pointer.
  bool contiguous_children = false;
  uint32_t max_leaf_triangles = 15;  // the leaf count field's capacity
  std::string summary;               // one line for --help and docs
  std::string source;                // where the layout comes from
};

// Every format rtsim knows, narrowest first.
const std::vector<NodeFormat>& node_formats();
// Throws InputError(field, "unknown node format 'x' (known: ...)").
const NodeFormat& node_format(const std::string& name, const std::string& field = "memory.node_format");
std::string node_format_names(const char* separator = ", ");

// Encodes `count` (1..format.width) child boxes into the box fields of one
// record of format.record_bytes bytes: the whole record is zero-filled first,
// then the box fields (for Quantized8 also the frame: origin and exponents) are
// written; links, counts and type bytes are left zero for the caller to fill.
// Child slots past `count` are encoded empty. For OwnBoxFp32 `count` is 1: the
// node's own box. Boxes must be non-empty with finite coordinates; a count out of
// range, an empty or non-finite box, or a format whose layout rtsim does not know
// throws std::invalid_argument (a programming error, not bad input).
void encode_child_boxes(const NodeFormat& format, const Aabb* boxes, uint32_t count,
                        uint8_t* record);
// Decodes child boxes [0, count) (count <= format.width) of a record
// encode_child_boxes wrote. A slot that was encoded empty decodes to an empty
// Aabb (Aabb::empty() is true).
void decode_child_boxes(const NodeFormat& format, const uint8_t* record, uint32_t count,
                        Aabb* out);

// IEEE 754 binary16 conversions behind BoxEncoding::Fp16 (public for tests).
// float_to_half rounds toward -inf (round_up false) or +inf (round_up true), so a
// finite value past the half range becomes +-65504 or +-inf, whichever lies on
// the requested side; infinities stay infinite. x must not be NaN.
uint16_t float_to_half(float x, bool round_up);
float half_to_float(uint16_t half);  // exact: every half is a float

}  // namespace rtsim
