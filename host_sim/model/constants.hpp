// Mathematical constants for the host code, defined once. Host only.
#pragma once

namespace feedid::host {

inline constexpr double kPi = 3.14159265358979323846;

}  // namespace feedid::host
