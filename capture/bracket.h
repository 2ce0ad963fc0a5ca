// Exposure lists and bracket scheduling: which exposure each captured frame gets.
#pragma once

#include <string>
#include <vector>

namespace gonio::capture {

// "16ms", "250us", "0.5s", "2" (seconds) or "1/125" (seconds) -> seconds. InputError naming
// `what` unless the result is a finite positive number.
double ParseDuration(const std::string& text, const std::string& what);

// A comma-separated list of durations ("1ms,4ms,16ms"); duplicates are an error, since a
// bracket with two equal exposures says nothing the response fit can use.
std::vector<double> ParseExposureList(const std::string& text, const std::string& what);

struct Shot {
  int bracket = 0;                // pose index
  double exposure_s = 0.0;        // requested exposure
  bool exposure_changes = false;  // differs from the previous shot: the source must settle
};

// num_brackets brackets, each taking every exposure once. Exposures run short to long in even
// brackets and long to short in odd ones, so consecutive brackets share their boundary exposure
// and the camera settles (drops frames) only (n - 1) times per bracket instead of n. A single
// bracket starts at the shortest exposure, which limits the heat and blooming of a long first
// frame. InputError for an empty list, a non-positive exposure or num_brackets < 1.
std::vector<Shot> ScheduleBrackets(const std::vector<double>& exposures_s, int num_brackets);

// "16 ms", "250 us", "2 s" for logs and reports.
std::string FormatDuration(double seconds);

}  // namespace gonio::capture
