#pragma once

#include <stdexcept>
#include <string>

namespace penumbra {

// The one error type of the project. Its message names the file, line, field or value that
// caused it, so the user can act on it without a debugger.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace penumbra
