#include "common/parse.h"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "common/error.h"

namespace gonio {

double ParseNumber(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw InputError(what + ": '" + text + "' is not a finite number");
  }
  return v;
}

Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) parts.push_back(item);
  if (parts.size() != 3) throw InputError(what + ": '" + text + "' is not X,Y,Z");
  return {ParseNumber(parts[0], what), ParseNumber(parts[1], what), ParseNumber(parts[2], what)};
}

}  // namespace gonio
