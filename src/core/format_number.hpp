// A double for a message: six significant digits ("1e+308", "1e-30", "0.0125"), never the 309
// digits or the "0.000000" that std::to_string gives for very large or small magnitudes.
#pragma once

#include <cstdio>
#include <string>

namespace sspc {

inline std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace sspc
