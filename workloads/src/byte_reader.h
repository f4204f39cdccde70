#pragma once
// Bounds-checked little-endian reads from a byte buffer, for the binary loaders
// (q3bsp.cpp, stk_track.cpp). Every read names the file, the offset and what was
// being read when it would run past the end, so a malformed file gives a clear
// InputError instead of a crash.
#include <rtsim/workloads/error.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace rtsim::detail {

class ByteReader {
 public:
  ByteReader(const std::vector<uint8_t>& bytes, std::string file_name)
      : bytes_(bytes), file_(std::move(file_name)) {}

  size_t size() const { return bytes_.size(); }
  const std::string& file() const { return file_; }

  // Throws unless [offset, offset + length) lies inside the buffer.
  void require(uint64_t offset, uint64_t length, const std::string& what) const {
    if (offset > bytes_.size() || length > bytes_.size() - offset)
      fail(offset, what + " (" + std::to_string(length) + " bytes) runs past the end of the file (" +
                       std::to_string(bytes_.size()) + " bytes)");
  }

  template <typename T>
  T at(uint64_t offset, const std::string& what) const {
    require(offset, sizeof(T), what);
    T value;
    std::memcpy(&value, bytes_.data() + offset, sizeof(T));
    return value;  // the formats are little-endian, like every host we build for
  }

  [[noreturn]] void fail(uint64_t offset, const std::string& reason) const {
    throw InputError(file_, "offset " + std::to_string(offset) + ": " + reason);
  }

  const uint8_t* data(uint64_t offset) const { return bytes_.data() + offset; }

 private:
  const std::vector<uint8_t>& bytes_;
  std::string file_;
};

// A forward cursor over a ByteReader (for stream formats such as SPM).
class ByteCursor {
 public:
  explicit ByteCursor(const ByteReader& reader) : reader_(reader) {}
  template <typename T>
  T read(const std::string& what) {
    const T value = reader_.at<T>(offset_, what);
    offset_ += sizeof(T);
    return value;
  }
  std::string read_string(uint64_t length, const std::string& what) {
    reader_.require(offset_, length, what);
    std::string s(reinterpret_cast<const char*>(reader_.data(offset_)), size_t(length));
    offset_ += length;
    return s;
  }
  void skip(uint64_t length, const std::string& what) {
    reader_.require(offset_, length, what);
    offset_ += length;
  }
  uint64_t offset() const { return offset_; }
  [[noreturn]] void fail(const std::string& reason) const { reader_.fail(offset_, reason); }

 private:
  const ByteReader& reader_;
  uint64_t offset_ = 0;
};

}  // namespace rtsim::detail
