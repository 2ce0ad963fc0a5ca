// Options that choose among a few words (--criterion bic, --robust huber, --lamp-frame board)
// are enums inside the libraries. The word is parsed once where it enters (the command line)
// and written back unchanged for fit.json and reports; each enum lists its words in one table
// that serves both directions.
#pragma once

#include <string>
#include <utility>

#include "common/error.h"

namespace gonio {

template <typename E>
using OptionWord = std::pair<E, const char*>;

// The enum value of `word`; InputError naming the option and the accepted words otherwise,
// e.g. "--criterion: 'r2' is not one of aic, bic, cv".
template <typename E, size_t N>
E ParseOptionWord(const OptionWord<E> (&table)[N], const std::string& word,
                  const std::string& option_name) {
  std::string known;
  for (const auto& [value, w] : table) {
    if (word == w) return value;
    known += (known.empty() ? "" : ", ") + std::string(w);
  }
  throw InputError(option_name + ": '" + word + "' is not one of " + known);
}

// The word of `value` ("?" for a value outside the table, which only a cast can produce).
template <typename E, size_t N>
std::string OptionWordOf(const OptionWord<E> (&table)[N], E value) {
  for (const auto& [v, w] : table) {
    if (v == value) return w;
  }
  return "?";
}

}  // namespace gonio
