// Where the lamp stays fixed while the photographs are taken. Both the renderer's scene
// (data_synth, scene.json lamp.frame) and the fit's hypothesis (estimation/joint, --lamp-frame)
// speak of it, and data_synth may not include estimation (docs/architecture.md "Layers"), so
// the enum and its one word table live here, below both.
#pragma once

#include <string>

#include "common/option_words.h"

namespace gonio {

// The board's frame (the camera moves around board and lamp) or the camera's (the board turns
// in front of a camera that carries the lamp).
enum class LampFrame { kBoard, kCamera };

inline constexpr OptionWord<LampFrame> kLampFrameWords[] = {{LampFrame::kBoard, "board"},
                                                            {LampFrame::kCamera, "camera"}};

// "board" or "camera"; InputError naming `option_name` otherwise.
inline LampFrame ParseLampFrame(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kLampFrameWords, word, option_name);
}
inline std::string ToString(LampFrame frame) { return OptionWordOf(kLampFrameWords, frame); }

}  // namespace gonio
