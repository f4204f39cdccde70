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

// Content hash of a file's bytes (rtsim::hash_bytes); throws std::runtime_error if unreadable.
uint64_t file_content_hash(const std::filesystem::path& path);

}  // namespace rtsim
