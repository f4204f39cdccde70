#pragma once
// Bad input (files, configs, command lines) raises InputError. The command line
// turns it into a message naming the file/key/field and exit code 2.
#include <stdexcept>
#include <string>

namespace rtsim {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
  // "<where>: <reason>", where is a file, a key or a field.
  InputError(const std::string& where, const std::string& reason)
      : std::runtime_error(where + ": " + reason) {}
};

constexpr int kExitBadInput = 2;

}  // namespace rtsim
