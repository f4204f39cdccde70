// PLY files checked against their own header before assimp reads them: assimp
// trusts the element counts of the header, so a body shorter than announced
// either aborts the process inside assimp's triangulation or loads as triangles
// made of zeros. Here every element the header announces must be present in the
// body (ASCII: enough numbers; binary: enough bytes, list lengths read from the
// data), and the header itself must be well formed.
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/mesh_loader.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace rtsim {

namespace {

enum class PlyFormat { Ascii, BinaryLittle, BinaryBig };

struct PlyProperty {
  std::string name;
  bool list = false;
  int count_bytes = 0;  // list: size of the length field
  bool count_signed = false;
  int value_bytes = 0;  // scalar, or each list item
  bool value_signed = false;
  bool value_integer = false;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

// Bytes of a PLY scalar type, 0 if the name is not one; `is_signed` for lengths.
int scalar_bytes(std::string_view type, bool* is_signed = nullptr) {
  struct Type {
    const char* name;
    int bytes;
    bool is_signed;
  };
  static const Type kTypes[] = {{"char", 1, true},     {"int8", 1, true},    {"uchar", 1, false},
                                {"uint8", 1, false},   {"short", 2, true},   {"int16", 2, true},
                                {"ushort", 2, false},  {"uint16", 2, false}, {"int", 4, true},
                                {"int32", 4, true},    {"uint", 4, false},   {"uint32", 4, false},
                                {"float", 4, true},    {"float32", 4, true}, {"double", 8, true},
                                {"float64", 8, true}};
  for (const Type& t : kTypes)
    if (type == t.name) {
      if (is_signed) *is_signed = t.is_signed;
      return t.bytes;
    }
  return 0;
}

std::vector<std::string_view> words_of(std::string_view line) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

bool whole_number(std::string_view text, uint64_t& out) {
  if (text.empty() || text.size() > 19) return false;
  uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + uint64_t(c - '0');
  }
  out = v;
  return true;
}

// Whitespace-separated numbers of an ASCII body, read one at a time.
class AsciiBody {
 public:
  AsciiBody(std::string_view text) : text_(text) {}
  // The next word, false at the end of the body.
  bool next(std::string_view& word) {
    while (at_ < text_.size() && is_space(text_[at_])) ++at_;
    if (at_ >= text_.size()) return false;
    const size_t start = at_;
    while (at_ < text_.size() && !is_space(text_[at_])) ++at_;
    word = text_.substr(start, at_ - start);
    return true;
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
  std::string_view text_;
  size_t at_ = 0;
};

bool is_number(std::string_view word) {
  // strtod needs a terminated string; PLY numbers are short.
  if (word.size() > 64) return false;
  char buffer[65];
  std::memcpy(buffer, word.data(), word.size());
  buffer[word.size()] = '\0';
  char* end = nullptr;
  std::strtod(buffer, &end);
  return end == buffer + word.size();
}

uint64_t read_unsigned(const uint8_t* p, int bytes, bool big_endian) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= uint64_t(p[big_endian ? bytes - 1 - i : i]) << (8 * i);
  return v;
}

}  // namespace

void check_ply_against_header(std::string_view bytes, const std::string& file) {
  auto fail = [&](const std::string& reason) { throw InputError(file, "PLY " + reason); };
  if (bytes.substr(0, 4) != "ply\n" && bytes.substr(0, 5) != "ply\r\n")
    fail("header: the file must start with the line 'ply'");

  // ---- header
  PlyFormat format = PlyFormat::Ascii;
  bool have_format = false;
  std::vector<PlyElement> elements;
  size_t at = bytes.find('\n') + 1;
  size_t body = std::string_view::npos;
  int line_number = 1;
  while (at < bytes.size()) {
    const size_t end = bytes.find('\n', at);
    if (end == std::string_view::npos) break;
    ++line_number;
    const std::string_view line = bytes.substr(at, end - at);
    at = end + 1;
    const std::vector<std::string_view> w = words_of(line);
    const std::string where = "header line " + std::to_string(line_number) + ": ";
    if (w.empty()) continue;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") {
      body = at;
      break;
    }
    if (w[0] == "format") {
      if (w.size() != 3) fail(where + "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (w[1] == "ascii") format = PlyFormat::Ascii;
      else if (w[1] == "binary_little_endian") format = PlyFormat::BinaryLittle;
      else if (w[1] == "binary_big_endian") format = PlyFormat::BinaryBig;
      else fail(where + "unknown format '" + std::string(w[1]) + "'");
      have_format = true;
    } else if (w[0] == "element") {
      uint64_t count = 0;
      if (w.size() != 3 || !whole_number(w[2], count))
        fail(where + "expected 'element <name> <count>' with a whole count");
      elements.push_back({std::string(w[1]), count, {}});
    } else if (w[0] == "property") {
      if (elements.empty()) fail(where + "a property before any element");
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        p.list = true;
        p.count_bytes = scalar_bytes(w[2], &p.count_signed);
        p.value_bytes = scalar_bytes(w[3], &p.value_signed);
        p.value_integer = w[3].find("float") == std::string_view::npos && w[3] != "double";
        if (!p.count_bytes || !p.value_bytes || w[2].find("float") != std::string_view::npos ||
            w[2] == "double")
          fail(where + "list types must be an integer length type and a scalar item type");
        p.name = std::string(w[4]);
      } else if (w.size() == 3 && scalar_bytes(w[1])) {
        p.value_bytes = scalar_bytes(w[1]);
        p.name = std::string(w[2]);
      } else {
        fail(where + "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      elements.back().properties.push_back(p);
    } else {
      fail(where + "unknown keyword '" + std::string(w[0]) + "'");
    }
  }
  if (!have_format) fail("header: no 'format' line");
  if (body == std::string_view::npos) fail("header: no 'end_header' line");

  // Faces: assimp's triangulation asserts (aborts) on a face of fewer than three
  // corners, and an index past the vertices is no triangle either; so each
  // face's vertex list is checked too.
  uint64_t vertex_count = 0;
  for (const PlyElement& e : elements)
    if (e.name == "vertex") vertex_count = e.count;
  auto is_face_list = [](const PlyElement& e, const PlyProperty& p) {
    return e.name == "face" && p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
  };
  auto bad_face = [&](uint64_t index, const std::string& why) {
    fail("body: face " + std::to_string(index) + " " + why);
  };
  auto check_corner = [&](uint64_t face, bool negative, uint64_t value) {
    if (negative || value >= vertex_count)
      bad_face(face, "names vertex " + std::string(negative ? "-" : "") + std::to_string(value) + ", but there are " +
                         std::to_string(vertex_count) + " vertices");
  };

  // ---- body: every element the header announces must be there
  auto short_body = [&](const PlyElement& e, uint64_t index) {
    fail("body ends early: the header announces " + std::to_string(e.count) + " '" + e.name +
         "' elements, the body holds " + std::to_string(index) + " of them (a truncated file?)");
  };
  if (format == PlyFormat::Ascii) {
    AsciiBody text(bytes.substr(body));
    std::string_view word;
    for (const PlyElement& e : elements) {
      if (e.properties.empty()) continue;  // no data to check, whatever the count
      for (uint64_t i = 0; i < e.count; ++i)
        for (const PlyProperty& p : e.properties) {
          if (!text.next(word)) short_body(e, i);
          if (!p.list) {
            if (!is_number(word))
              fail("body: '" + std::string(word.substr(0, 32)) + "' in element '" + e.name + "' " +
                   std::to_string(i) + " is not a number");
            continue;
          }
          uint64_t length = 0;
          if (!whole_number(word, length))
            fail("body: list length '" + std::string(word.substr(0, 32)) + "' of element '" + e.name +
                 "' " + std::to_string(i) + " is not a whole number");
          const bool face = is_face_list(e, p);
          if (face && length < 3) bad_face(i, "has " + std::to_string(length) + " corners (at least 3 make a face)");
          for (uint64_t k = 0; k < length; ++k) {
            if (!text.next(word)) short_body(e, i);
            if (!is_number(word))
              fail("body: '" + std::string(word.substr(0, 32)) + "' in element '" + e.name + "' " +
                   std::to_string(i) + " is not a number");
            if (face) {
              uint64_t corner = 0;
              const bool negative = !word.empty() && word[0] == '-';
              if (!whole_number(negative ? word.substr(1) : word, corner))
                bad_face(i, "has the corner '" + std::string(word.substr(0, 32)) + "', not a vertex index");
              check_corner(i, negative, corner);
            }
          }
        }
    }
    return;
  }
  const bool big_endian = format == PlyFormat::BinaryBig;
  const uint8_t* data = reinterpret_cast<const uint8_t*>(bytes.data());
  uint64_t offset = body;
  const uint64_t size = bytes.size();
  for (const PlyElement& e : elements) {
    if (e.properties.empty()) continue;
    bool fixed = true;
    uint64_t fixed_bytes = 0;
    for (const PlyProperty& p : e.properties) {
      fixed = fixed && !p.list;
      fixed_bytes += uint64_t(p.list ? p.count_bytes : p.value_bytes);
    }
    // Each element takes at least fixed_bytes: a count the rest of the file cannot
    // hold is refused at once, without walking a loop of that length.
    if (e.count > (size - offset) / fixed_bytes) {
      if (fixed) short_body(e, (size - offset) / fixed_bytes);
    }
    if (fixed) {
      offset += e.count * fixed_bytes;
      continue;
    }
    for (uint64_t i = 0; i < e.count; ++i)
      for (const PlyProperty& p : e.properties) {
        if (!p.list) {
          if (size - offset < uint64_t(p.value_bytes)) short_body(e, i);
          offset += uint64_t(p.value_bytes);
          continue;
        }
        if (size - offset < uint64_t(p.count_bytes)) short_body(e, i);
        uint64_t length = read_unsigned(data + offset, p.count_bytes, big_endian);
        if (p.count_signed && (length >> (8 * p.count_bytes - 1)))
          fail("body: element '" + e.name + "' " + std::to_string(i) + " has a negative list length");
        offset += uint64_t(p.count_bytes);
        if (length > (size - offset) / uint64_t(p.value_bytes)) short_body(e, i);
        if (is_face_list(e, p)) {
          if (length < 3) bad_face(i, "has " + std::to_string(length) + " corners (at least 3 make a face)");
          if (!p.value_integer) bad_face(i, "has vertex indices of a floating-point type");
          for (uint64_t k = 0; k < length; ++k) {
            const uint64_t raw = read_unsigned(data + offset + k * uint64_t(p.value_bytes), p.value_bytes, big_endian);
            const int bits = 8 * p.value_bytes;
            const bool negative = p.value_signed && (raw >> (bits - 1));
            const uint64_t magnitude = negative ? (bits == 64 ? ~raw + 1 : ((uint64_t(1) << bits) - raw)) : raw;
            check_corner(i, negative, magnitude);
          }
        }
        offset += length * uint64_t(p.value_bytes);
      }
  }
}

}  // namespace rtsim
