#pragma once

#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace penumbra::gpu {

enum class Severity { verbose, info, warning, error };

struct ValidationMessage {
  Severity severity = Severity::error;
  std::string id;       // VUID or message id name, e.g. "VUID-vkCmdDispatch-None-08606"
  std::string message;  // full text from the validation layer
};

// Collects validation-layer messages of warning and error severity. Thread-safe: the layer may
// call from any thread. Tests consume the messages they caused with take().
//
// Shader debug printf output (GL_EXT_debug_printf, ContextOptions::debug_printf) is not a
// validation message: it is kept apart, and take_printf() consumes it.
class ValidationSink {
 public:
  void push(ValidationMessage message);
  std::vector<ValidationMessage> take();  // returns and clears the collected messages
  size_t count() const;
  size_t total_seen() const;  // every message ever pushed, never reset
  void push_printf(std::string message);
  std::vector<std::string> take_printf();

 private:
  mutable std::mutex mutex_;
  std::vector<ValidationMessage> messages_;
  std::vector<std::string> printf_;
  size_t total_ = 0;
};

std::string to_string(const ValidationMessage& message);

// Takes the sink's messages and throws penumbra::Error listing them, if there are any: what a
// tool run with PENUMBRA_VALIDATION=1 does, so that any message fails it.
void throw_if_messages(ValidationSink& sink);

}  // namespace penumbra::gpu
