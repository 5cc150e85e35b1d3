// Numbers as messages print them.
#pragma once

#include <cstdio>
#include <string>

namespace basis {

// A number with six significant digits (printf's %g): 1e-09 stays 1e-09, where std::to_string
// would print 0.000000.
inline std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace basis
