#include "gatcore/progress.hpp"

#include <cstdio>

namespace gatcore {

void report_warning(const WarningFn& fn, const std::string& message) {
  if (fn) fn(message);
  else std::fprintf(stderr, "warning: %s\n", message.c_str());
}

}  // namespace gatcore
