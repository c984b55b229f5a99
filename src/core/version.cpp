#include "dronetwin/core/version.hpp"

#ifndef DRONETWIN_VERSION
#error "DRONETWIN_VERSION must be defined by the build (CMakeLists.txt)"
#endif

namespace dronetwin {

std::string_view version() { return DRONETWIN_VERSION; }

}  // namespace dronetwin
