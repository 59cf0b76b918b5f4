// The library's version, compiled in from the generated header.
#include "qbond/version.hpp"

namespace qbond {

std::string_view version() { return QBOND_VERSION; }

}  // namespace qbond
