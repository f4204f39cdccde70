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

// Content hash of a file's bytes (rtsim::hash_bytes); throws std::runtime_error if unreadable.
uint64_t file_content_hash(const std::filesystem::path& path);

}  // namespace rtsim
