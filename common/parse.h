// Parsing of command-line and file values, written once so every option reports bad input the
// same way: InputError naming the option (`what`) and the text.
#pragma once

#include <string>

#include <Eigen/Core>

namespace gonio {

// A finite double; InputError "what: 'text' is not a finite number" otherwise (so "nan",
// "inf" and "1e999" are refused, not passed on).
double ParseNumber(const std::string& text, const std::string& what);

// "X,Y,Z" with three finite numbers; InputError "what: 'text' is not X,Y,Z ..." otherwise.
Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what);

}  // namespace gonio
