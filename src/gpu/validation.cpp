#include <penumbra/core/error.hpp>
#include <penumbra/gpu/validation.hpp>

namespace penumbra::gpu {

void ValidationSink::push(ValidationMessage message) {
  std::lock_guard lock(mutex_);
  messages_.push_back(std::move(message));
  ++total_;
}

std::vector<ValidationMessage> ValidationSink::take() {
  std::lock_guard lock(mutex_);
  std::vector<ValidationMessage> out;
  out.swap(messages_);
  return out;
}

void ValidationSink::push_printf(std::string message) {
  std::lock_guard lock(mutex_);
  printf_.push_back(std::move(message));
}

std::vector<std::string> ValidationSink::take_printf() {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  out.swap(printf_);
  return out;
}

size_t ValidationSink::count() const {
  std::lock_guard lock(mutex_);
  return messages_.size();
}

size_t ValidationSink::total_seen() const {
  std::lock_guard lock(mutex_);
  return total_;
}

std::string to_string(const ValidationMessage& message) {
  const char* severity = "error";
  switch (message.severity) {
    case Severity::verbose:
      severity = "verbose";
      break;
    case Severity::info:
      severity = "info";
      break;
    case Severity::warning:
      severity = "warning";
      break;
    case Severity::error:
      severity = "error";
      break;
  }
  return std::string("[validation ") + severity + "] " + message.id + ": " + message.message;
}

void throw_if_messages(ValidationSink& sink) {
  const auto messages = sink.take();
  if (messages.empty()) return;
  std::string text;
  for (const auto& m : messages) text += "\n  " + to_string(m);
  throw Error("validation layer reported " + std::to_string(messages.size()) + " message(s):" +
              text);
}

}  // namespace penumbra::gpu
