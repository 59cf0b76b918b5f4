#pragma once
// Raising the module's own exceptions from the bindings.
#include <string>

namespace qbond::python {

/// Raises qbond.BlowupError with `message` (the step report's).
[[noreturn]] void raise_blowup(const std::string& message);

}  // namespace qbond::python
