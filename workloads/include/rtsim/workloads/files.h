#pragma once
// Output files are written to a temporary name and renamed into place, so a
// crash or a kill never leaves a half-written result behind.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>

namespace rtsim {

// Calls write(stream) on a temporary file beside `path`, then renames it to `path`.
// Throws std::runtime_error naming the file if anything fails (the temp is removed).
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write);
void write_file_atomic(const std::filesystem::path& path, const std::string& contents);

// Whether a path names something, a regular file, a folder. A path that cannot
// even be asked about (a name too long for the file system, a component that is
// not a folder, no permission) is none of these: false, never an exception, so
// readers of user-given paths answer with their own InputError.
bool path_exists(const std::filesystem::path& path);
bool is_file(const std::filesystem::path& path);
bool is_folder(const std::filesystem::path& path);

// Reading user-given files is bounded: only a regular file (symlinks followed) of
// at most `max_bytes` is read. A folder, a FIFO, a device or a socket is refused
// before it is opened, so no read can block forever or grow without bound; a file
// past the limit is refused by its size. InputError naming the file otherwise.
// The limits (docs/robustness.md): text configurations (scene descriptors,
// hardware files, campaign files, result files) 64 MiB; meshes, BVH files and ray
// files 4 GiB.
constexpr uint64_t kMaxConfigFileBytes = uint64_t(64) << 20;
constexpr uint64_t kMaxDataFileBytes = uint64_t(4) << 30;
std::string read_input_file(const std::filesystem::path& path, uint64_t max_bytes);
// The same checks without reading, for paths handed to a library that opens the
// file itself (assimp, libzip, pugixml). Returns the file's size.
uint64_t check_input_file(const std::filesystem::path& path, uint64_t max_bytes);

// Content hash of a file's bytes (rtsim::hash_bytes); InputError if it cannot be read.
uint64_t file_content_hash(const std::filesystem::path& path);

}  // namespace rtsim
