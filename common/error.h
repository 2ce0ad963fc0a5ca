// Error types shared by every gonio library.
//
// The CLI maps InputError to exit code 2 with its message on one line, so every message
// must name the file (or parameter) and the problem, e.g. "board.json: unknown key 'foo'".
#pragma once

#include <stdexcept>
#include <string>

namespace gonio {

// The user's input is wrong: a missing or corrupt file, a nonsense parameter, data that
// cannot constrain what was asked. Exit code 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A numerical method could not produce a valid value for valid input (it reports why
// instead of returning NaN or Inf). Exit code 3.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace gonio
