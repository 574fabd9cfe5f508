#include "gipdyn/version.hpp"

#ifndef GIPDYN_VERSION_STRING
#error "GIPDYN_VERSION_STRING must be defined by the build (CMake's project version)"
#endif

namespace gipdyn {

const char* version() { return GIPDYN_VERSION_STRING; }

}  // namespace gipdyn
