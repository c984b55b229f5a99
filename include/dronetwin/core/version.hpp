#pragma once
// The dronetwin version this library was built as (the CMake project version, e.g. "0.1.0"), as
// logs, sidecars and `dronetwin --version` report it.

#include <string_view>

namespace dronetwin {

std::string_view version();

}  // namespace dronetwin
