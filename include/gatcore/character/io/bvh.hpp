#pragma once
// BVH motion capture import (gatcore's own strict reader; see bvh.cpp for
// why not assimp).
#include <string>
#include <string_view>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/progress.hpp"

namespace gatcore::character {

// Reads a BVH file (one ROOT hierarchy), one pose per file frame
// (clip.fps = 1 / Frame Time). Throws InvalidArgument naming the file, the
// line and the problem (unreadable, truncated, unknown keyword or channel,
// no frames, Frame Time <= 0, non-finite numbers, a partial last frame).
// Lenient where the intent is clear: any rotation order, position channels
// on any joint, no End Site, CRLF / tabs / trailing blanks; a Frames: count
// that disagrees with the rows present reads the whole frames present and
// reports both numbers through `warn` (stderr without one).
Motion load_bvh(const std::string& path, const WarningFn& warn = {});
// The same from the file's contents (`path` names it in errors).
Motion parse_bvh(std::string_view text, const std::string& path, const WarningFn& warn = {});

}  // namespace gatcore::character
