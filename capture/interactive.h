// The interactive wait before each exposure bracket (gonio capture --interactive,
// docs/capture.md): the user places the board, then captures or stops.
#pragma once

#include "capture/frame_source.h"
#include "capture/session_writer.h"

namespace gonio::capture {

// Whether a display is there for a preview window (DISPLAY or WAYLAND_DISPLAY set).
bool HaveDisplay();

// With a display, a live preview of `source` at the middle of the bracket's exposures (SPACE or
// ENTER captures, Q or ESC stops); without one, PromptBeforeBracket on stdin and stderr.
// `source` and `options` must outlive the returned function.
BeforeBracket InteractiveBeforeBracket(FrameSource& source, const BracketOptions& options);

}  // namespace gonio::capture
