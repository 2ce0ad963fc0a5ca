// Inverse camera response from an exposure sweep of a static scene (radiometric
// self-calibration).
//
// Model: for pixel p in frame j with value Z, h(Z) = ln E_p + ln t_j, where h = ln of the
// inverse response (pixel value -> relative exposure, irradiance x time). h is non-parametric
// (piecewise linear on knots over the value range, so any bit depth works), fitted with Ceres
// jointly with every pixel's ln E, as Debevec-Malik do. The listed exposure times of the frames
// that agree with each other are held exactly, which fixes the exponent ambiguity of
// self-calibration (Mitsunaga-Nayar); a frame whose listed time contradicts the others by more
// than the curve's own uncertainty is found (response_times.cc), reported, and either re-timed
// (its ln t free) or left out. Monotonicity is enforced afterwards by
// isotonic regression (pool adjacent violators). Saturated and dark values get zero weight;
// unlike the TUM monoVO tool nothing divides by a count that can be zero. docs/photometric.md
// describes the method, its self-check and its refusals.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace gonio {

struct ExposureFrame {
  std::string file;
  double exposure_s = 0;  // as listed (EXIF, list file, session)
  cv::Mat image;          // CV_8U or CV_16U, 1 or 3 channels
  cv::Mat mask;           // CV_8U, non-zero where the frame may be used; empty: everywhere
};

// A sweep as read from a folder: the frames, and the bit depth (0: none), black level and dark
// frames (lens capped, same settings) its session.json states.
struct ExposureSweep {
  std::vector<ExposureFrame> frames;
  int bit_depth = 0;
  std::string bit_depth_source;  // the file that stated it
  std::optional<double> black_level;
  std::vector<ExposureFrame> dark_frames;  // exposure_s 0
  std::string session_file;                // empty: no session.json
};

// Where a black level came from: measured on dark frames, stated (session.json, the
// --black-level option, the RAW file's metadata, subtracted on import), assumed (no calibration
// given; the run records the assumption) or estimated from the response curve's shape.
enum class BlackLevelSource { kEstimated, kOption, kSession, kDarkFrames, kRawMetadata, kAssumed };
// "estimated", "option", "session.json", "dark frames", "RAW metadata", "assumed"
// (response.json black_level_source).
const char* BlackLevelSourceName(BlackLevelSource source);

// How N significant bits sit in the frames' container.
enum class ValuePacking { kNative, kLsbAligned, kMsbAligned };

struct ResponseOptions {
  int bit_depth = 0;  // 0: from the image type (8 or 16); see ResolveBitDepth
  // Given for every channel (black_level_source says by whom) or, when empty and
  // channel_black_level is empty too, estimated from the curve's shape.
  std::optional<double> black_level;
  std::vector<double> channel_black_level;  // per channel (dark frames); overrides black_level
  BlackLevelSource black_level_source = BlackLevelSource::kOption;
  int num_knots = 128;  // knots of h over [0, 2^bit_depth)
  // Sampled pixels per channel; 0: by the frames (PixelsFor, docs/photometric.md "How many
  // pixels"). On 8-bit frames a value's quantization is a large part of each pixel's error, the
  // part more pixels average out, and the session's statistical bars shrink with its frames'
  // pixel count: with a fixed sample the response's noise part, the one whose draws a single
  // sweep gets most wrong, grew to the largest share of the bars at 1280x960 (the coverage
  // bench's sRGB kinds: lamp z RMS z 1.58, 75 % within 2; at 6000 pixels 1.30 with a third to two
  // fifths less error). On 12- and 16-bit sweeps 6000 pixels left the errors as they were and
  // took 4 times as long on the demo's sweep, so those keep 1500.
  int num_pixels = 0;
  // On 8-bit frames when num_pixels is 0: 1500 per 640x480 frame (the fixed default until
  // 2026-12-06, at the size of the coverage bench's grid, whose bars are measured at it), within
  // these bounds (about 9 s per channel at the top).
  static constexpr double kPixelsPerFramePixel = 1500.0 / (640 * 480);
  static constexpr int kMinPixels = 1500, kMaxPixels = 20000;
  // The sample for frames of `width` x `height` holding `bits` significant bits.
  int PixelsFor(int width, int height, int bits) const;
  // Refits on the pixels drawn again with replacement: the table's statistical error
  // (ResponseResult::bootstrap_ln_change; 0: not measured). Twenty: one per draw of the
  // calibration's propagation (CalibrationPropagationOptions::draws,
  // estimation/joint/calibration_error.h). With ten (until 2026-12-05) every refit was drawn
  // twice, and that part of a bar had the relative error of ten draws, not twenty.
  int bootstrap_refits = 20;
  std::uint64_t bootstrap_seed = 1;
  double smoothness = 1.0;           // weight of h's curvature (the same at any num_knots)
  double exposure_tolerance = 0.05;  // relative mismatch that marks a frame inconsistent
  bool drop_inconsistent = false;    // leave inconsistent frames out instead of re-timing
  double saturation_margin = 0.02;   // fraction of the range below the maximum treated as saturated
  // Refused (InputError) when the values the fit is supported by span less than this fraction
  // of the stated range: the bit depth is wrong or the sweep too narrow.
  double min_range_fraction = 0.25;
  // Refused (InputError) when the value-to-value mapping between neighbouring frames differs
  // between image regions by more than this (fraction of the mapping's step; local tone
  // mapping). Measured: 0.06-0.07 on the real sweeps, 0.03 on a synthetic one-curve sweep, 0.59
  // on a synthetic locally tone-mapped one.
  double max_regional_mapping_difference = 0.2;
  int threads = 0;

  void Check() const;
};

struct FrameExposureReport {
  std::string file;
  double listed_s = 0;
  double estimated_s = 0;  // from the fit (equal to listed when consistent)
  bool consistent = true;
  bool used = true;
  std::string note;
};

// Pair consistency (the metric of docs/photometric.md): for neighbouring used exposures a, b and
// every pixel well exposed in both, |(X(Z_a) / X(Z_b)) / (t_a / t_b) - 1|; per pair its median
// over pixels. `band_bias`: the signed error (X_a / X_b) / (t_a / t_b) - 1 in each of `kBands`
// equal parts of the checked value range, evaluated at the medians of groups of pixels that a
// third frame's value selects (free of noise, see BandErrors in response_check.cc), median over
// pairs and groups, so a curve wrong anywhere in the range it returns shows.
struct PairConsistency {
  static constexpr int kBands = 8;
  std::vector<double> per_pair;       // NaN for a pair with too few pixels
  double median_pair = NAN;           // median over pairs
  double worst_pair = NAN;            // maximum over pairs
  std::vector<double> band_bias;      // kBands values (NaN where no pixel falls)
  double worst_band_bias = NAN;       // largest |band_bias|
  double range_lo = 0, range_hi = 0;  // the checked value range
  nlohmann::json ToJson() const;
  // What ToJson wrote (null: NaN); InputError naming `source` on a wrong type or a negative
  // or non-finite figure.
  static PairConsistency FromJson(const nlohmann::json& j, const std::string& source);
};

// The stiffer prior the smoothing sensitivity refits with (response_smoothing.cc): 4x the
// smoothness (twice the curvature penalty's scale), enough to straighten what only the prior
// holds up between data.
constexpr double kSmoothingSensitivityFactor = 4.0;

// Above this smoothing sensitivity (its worst band) the response report names what would pin
// the curve, by the sweep's steps (SweepRemedy; docs/photometric.md "Smoothing sensitivity"). The
// worst band is mostly the dark end's, which third-stop sweeps also reach (0.13-1.0 % on the
// coverage bench).
constexpr double kSmoothingSensitivityLimit = 0.01;

// Above this smoothing sensitivity where a sample's raw values are (PhotometricCalibration::
// SmoothingSensitivityAt), the curve there is the prior's, not the sweep's: gonio run warns that
// the response limits the result (pipeline/run.cc). Measured at the sample's values on the
// coverage bench's five camera and scene kinds: 0.02-0.12 % for third-stop sweeps (what the
// capture guide asks), 0.39-2.4 % for whole stops, whose results were then off by up to 8 deg in
// sigma and 18 % in the lamp's distance. The limit sits between, a factor 1.7 and 2 from either
// side.
constexpr double kPriorHeldLimitAtValues = 0.002;

// One end of a channel's table where the sweep's data thin out (docs/photometric.md, "The
// table's ends"). Below the lowest value the data support the table is a straight line to the
// black level, anchored at that value's knot; near the highest, the curve rests on few samples.
// There the smoothing prior, not the data, holds the curve up, and a ratio self-check cannot see
// a gain error of a whole segment. `error`: the relative change of the table at `end` under the
// stiffer prior SmoothingSensitivity refits with (the common offset removed), taken as the
// 1-sigma error of every value beyond `end`, tapering linearly to 0 at `taper_to` (two knots
// inside). Measured on the flash preset's 12-bit sweep: 4.0 % at the dark end for a table 3.0 %
// off there.
struct ResponseEnd {
  int channel = 0;
  double end = 0;       // value: beyond it (below a dark end, above a bright one) the full error
  double taper_to = 0;  // value where the error has tapered to 0
  double error = 0;     // relative, 1 sigma
  // The error's weight at value z: 1 beyond `end`, 0 beyond `taper_to`, linear between.
  double WeightAt(double z) const;
};

// An inverse response table by raw value (ResponseResult::inverse_response[channel]) at `value`:
// linear between its entries, clamped to the table.
double LinearizeTable(const std::vector<double>& table, double value);

struct ResponseResult {
  int bit_depth = 8;
  int channels = 1;
  std::vector<double> black_level;  // per channel, in pixel values
  BlackLevelSource black_level_source = BlackLevelSource::kEstimated;
  // Per channel [lo, hi]: the black levels the data allow. Measured or stated: the value itself;
  // estimated: those whose power law fits the dark end as straight as the best within the
  // fit's noise, capped by the pedestal the darkest frame shows (response_black.cc).
  std::vector<std::array<double, 2>> black_level_range;
  std::vector<double> saturation_level;  // per channel: values at or above are saturated
  std::vector<std::vector<double>> inverse_response;  // [channel][value]: relative exposure
  std::vector<FrameExposureReport> frames;
  // The self-check over the whole returned range (black level to saturation level).
  PairConsistency consistency;
  double rms_log_residual = 0;  // of the fit, ln units
  // Largest difference between image regions of the value-to-value mapping of neighbouring
  // frames (fraction of the range; see RegionalMappingDifference).
  double regional_mapping_difference = 0;
  // Relative change of the curve when refitted with a 4x stiffer smoothing prior, worst value
  // band (SmoothingSensitivity, docs/photometric.md): the part of its error between the values
  // the sweep holds, which the self-check cannot see. NaN: not measured (older files,
  // smoothness 0).
  double smoothing_sensitivity = NAN;
  // The same per band of the self-check's range (PairConsistency::kBands, the largest over the
  // channels; NaN where no knot falls), so a user of the table can read it where its own values
  // are (PhotometricCalibration::SmoothingSensitivityAt). Empty in older files.
  std::vector<double> smoothing_sensitivity_bands;
  // The table's ends where the prior holds it (see ResponseEnd): empty in older files and with
  // smoothness 0.
  std::vector<ResponseEnd> ends;
  // Values between the fit's knots (its curve's own scale): the scale of the wiggles the
  // smoothing sensitivity measures. NaN in older files.
  double knot_spacing = NAN;
  // The table's statistical error (BootstrapResponse, docs/photometric.md): per pixel-bootstrap
  // refit and channel, the change of ln X at every knot (knot k at value k * knot_spacing), the
  // common offset removed. Empty in older files and with ResponseOptions::bootstrap_refits 0.
  std::vector<std::vector<std::vector<double>>> bootstrap_ln_change;
  int sampled_pixels = 0;  // per channel, the sample the curve was fitted to (0: older files)

  // Relative exposure of a (possibly fractional) pixel value, linear between table entries.
  double Linearize(int channel, double value) const;
  // Derivative dX/dZ at a value (for propagating pixel noise).
  double Slope(int channel, double value) const;
  // Linearize of every pixel value 0 .. 2^bit_depth - 1, per channel, clamped at 0: the table
  // the tag detectors read radiance through (calib/geometry/detect.h RadianceTable).
  std::vector<std::vector<float>> RadianceByValue() const;
  // Whether the black levels the data allow span more than 2 % of the range in a channel (the
  // CLI then warns and recommends dark frames).
  bool BlackLevelUncertain() const;
  std::string Report() const;
  nlohmann::json ToJson() const;
  // InputError naming `source` on a malformed file.
  static ResponseResult FromJson(const nlohmann::json& j, const std::string& source);
};

// The sweep's exposure step in octaves: the median log2 ratio of neighbouring used frames'
// times (1 without frames: a whole stop). What a ratio check ties, and what it leaves free:
// any error periodic in log2 of the exposure with this period.
double ExposureStepOctaves(const ResponseResult& response);
// The period an error of the inverse response can have and still pass every tie: the
// largest p, among the median step / k for k = 1..6, that every step is a whole multiple of
// (within 0.03 octave). Equal whole stops leave one octave, third stops or steps of 2-5
// thirds one third (capture::IrregularLadder, docs/photometric.md "Irregular steps"); steps
// with no such period give the median step (no periodic error is free then, and the
// smoothing sensitivity's bands, which scale its draws, are small). 1 without frames.
double ExposurePeriodOctaves(const ResponseResult& response);
// What narrows the response's prior-held error, for a sweep whose steps leave
// `period_octaves` free (0: not known): third stops or steps that are not all equal when
// that is coarser than a third, else a scene with more radiance levels or RAW.
std::string SweepRemedy(double period_octaves);

// Frames from a folder and a list file ("file exposure_s [...]" per line, '#' comments), as in
// hdr_sweep/desktop/image_list.txt. InputError naming the file on unreadable images, mismatched
// sizes or types, or fewer than two exposures.
std::vector<ExposureFrame> LoadExposureSweep(const std::string& dir, const std::string& list_file);

// A sweep folder: with `list_file` empty and DIR/session.json present, the session's frames and
// times; else the list file (default DIR/image_list.txt). Either way the bit depth is the one
// DIR/session.json states, if any.
ExposureSweep LoadSweepFolder(const std::string& dir, const std::string& list_file);

// The black level to calibrate with (docs/photometric.md "Black level"): `option` (--black-level),
// the sweep's session.json black_level and its dark frames. Option and session must agree (within
// half a value); dark frames are measured (MeasureBlackLevel) and must agree with a stated level
// within 1 % of the range. Sets o->black_level or o->channel_black_level and
// o->black_level_source; leaves both empty (estimate) when nothing is given. `frames`: the sweep
// after ResolveBitDepth. InputError naming the file or option otherwise.
void ResolveBlackLevel(const ExposureSweep& sweep, std::optional<double> option,
                       const std::vector<ExposureFrame>& frames, int bit_depth, ResponseOptions* o);

// Per channel, the black level dark frames show: where at least 30 % of their values pile up on
// the lowest value (a pipeline that clips noise at its pedestal), that value; otherwise the
// median. InputError naming a dark frame whose size or type differs from the sweep's, whose
// values reach more than 10 % of the range above its black level, or whose black level lies
// more than 2 % of the range above the darkest values of the sweep's shortest frame (light
// reaching the sensor).
std::vector<double> MeasureBlackLevel(const std::vector<ExposureFrame>& dark,
                                      const std::vector<ExposureFrame>& frames, int bit_depth);

// Reads dark frames (lens capped, the sweep's settings; docs/capture.md) into sweep->dark_frames:
// `files` relative to `dir` or absolute. InputError naming a file that is not an image.
void AddDarkFrames(const std::string& dir, const std::vector<std::string>& files,
                   ExposureSweep* sweep);

// Marks pixels of exactly colour `bgr` as unusable in each frame's mask (e.g. the pure blue
// borders of the registered Memorial Church scans).
void MaskColour(const cv::Scalar& bgr, std::vector<ExposureFrame>* frames);

// The bit depth to calibrate with: `stated` (session.json or option; 0: none) checked against
// every frame. In a 16-bit container N < 16 bits are LSB-aligned (values < 2^N) or MSB-aligned
// (every value a multiple of 2^(16 - N)). Without a stated depth the container's is used.
// InputError naming the frame on MSB-aligned values (with the shift to apply: gonio reads
// LSB-aligned values), on a value the stated depth cannot hold, or on an 8-bit container with
// another stated depth.
int ResolveBitDepth(int stated, const std::string& stated_by, std::vector<ExposureFrame>* frames,
                    ValuePacking* packing = nullptr);

ResponseResult CalibrateResponse(const std::vector<ExposureFrame>& frames,
                                 const ResponseOptions& options);

// Pair consistency (above) of any inverse response on the frames with `used` true, at the
// given times, counting pixels with values in [lo, hi] in both frames (per channel) and inside
// both frames' masks. Defined in response_check.cc.
PairConsistency MeasurePairConsistency(const std::vector<ExposureFrame>& frames,
                                       const std::vector<double>& exposures_s,
                                       const std::vector<bool>& used,
                                       const std::vector<std::vector<double>>& inverse_response,
                                       const std::vector<double>& lo,
                                       const std::vector<double>& hi);

// The classic methods as OpenCV implements them (cv::CalibrateDebevec, cv::CalibrateRobertson,
// default parameters), on 8-bit frames with the given times: their inverse responses in the
// layout of ResponseResult::inverse_response. InputError for other bit depths.
std::vector<std::vector<double>> DebevecInverseResponse(const std::vector<ExposureFrame>& frames,
                                                        const std::vector<double>& exposures_s);
std::vector<std::vector<double>> RobertsonInverseResponse(const std::vector<ExposureFrame>& frames,
                                                          const std::vector<double>& exposures_s);

// gonio's result, then OpenCV's Debevec and Robertson (`methods`, in its order), all on the
// frames gonio used at the times it used (re-timed where it re-timed), checked on the same
// pixels: values in [5 %, 95 %] of the range and inside gonio's black..saturation range. 8-bit
// frames only (InputError otherwise). Each method's calibration time is measured here for
// OpenCV's; gonio's is the caller's (`gonio_calibrate_s`, the time CalibrateResponse took), so
// they are comparable. Robertson iterates over every pixel: on the 13-frame real desktop sweep
// it takes 10-14 s where Debevec takes 0.2 s.
struct MethodConsistency {
  std::string method;
  PairConsistency consistency;
  double calibrate_s = 0;  // wall time of the method's calibration alone
};
enum class ClassicMethod { kDebevec, kRobertson };
std::vector<MethodConsistency> CompareWithClassicMethods(
    const std::vector<ExposureFrame>& frames, const ResponseResult& result,
    double gonio_calibrate_s,
    const std::vector<ClassicMethod>& methods = {ClassicMethod::kDebevec,
                                                 ClassicMethod::kRobertson});

// Non-stationary processing check: for each pair of neighbouring frames (by listed time), the
// whole image's value-to-value mapping (median longer-exposure value per bin of the shorter's)
// and, in each cell of a 4x4 grid and each bin, the cell's median departure from it, as a
// fraction of the mapping's step there (longer - shorter value, at least 2 % of the range). A
// camera with one response gives one mapping everywhere; local tone mapping or HDR merging gives
// a different one per region. Returns the median over pairs of the 75th percentile of the
// departures: lens glare or a misregistered scan moves a few cells of a few pairs, a local tone
// curve most of them.
double RegionalMappingDifference(const std::vector<ExposureFrame>& frames, int bit_depth);

}  // namespace gonio
