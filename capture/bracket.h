// Exposure lists and bracket scheduling: which exposure each captured frame gets.
#pragma once

#include <string>
#include <vector>

namespace gonio::capture {

// "16ms", "250us", "0.5s", "2" (seconds) or "1/125" (seconds) -> seconds. InputError naming
// `what` unless the result is a finite positive number.
double ParseDuration(const std::string& text, const std::string& what);

// A comma-separated list of durations ("1ms,4ms,16ms"); duplicates are an error, since a
// bracket with two equal exposures says nothing the response fit can use. "A..B:N" (e.g.
// "1/4000..4:14") is the IrregularLadder of N exposures from A to B.
std::vector<double> ParseExposureList(const std::string& text, const std::string& what);

// An exposure sweep of `frames` exposures for the response fit, on the third-stop lattice
// 2^(k/3) s (the shutter speeds a camera offers in third stops, ShutterSpeedName), from
// `shortest_s` to `longest_s` (each rounded to the lattice), its steps whole multiples of a
// third of a stop but not all equal, and with no common factor larger than one third (all one
// third when the range holds no more than frames - 1 thirds).
//
// Why: frames a ratio r apart tie only ln X(z') - ln X(z) = ln r, so an error of the inverse
// response that is periodic in log2 X with a period dividing every step's passes every tie
// and is left to the smoothing prior (docs/photometric.md "Irregular steps"). Equal whole
// stops leave a period of one stop, which the prior fills with 0.9-1.3 % wiggles; steps of
// 2, 3 and 4 thirds leave one third, as a sweep in third stops does, with a third of its
// frames. The gaps are the mean gap jittered by a fixed low-discrepancy sequence, so the same
// arguments give the same ladder. InputError when the range holds fewer than frames - 1
// thirds, frames < 3 or a bound is not positive.
std::vector<double> IrregularLadder(double shortest_s, double longest_s, int frames,
                                    const std::string& what);

// The camera's name for the third-stop shutter speed nearest `seconds` ("1/320", "0.6",
// "13"), or "" outside 1/8000 .. 30 s.
std::string ShutterSpeedName(double seconds);

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
