#pragma once
// BVH motion capture import (gatcore's own strict reader; see bvh.cpp for
// why not assimp).
#include <string>
#include <string_view>

#include "gatcore/character/rig/motion.hpp"

namespace gatcore::character {

// Reads a BVH file (one ROOT hierarchy), one pose per file frame
// (clip.fps = 1 / Frame Time). Throws InvalidArgument naming the file, the
// line and the problem (unreadable, truncated, unknown keyword or channel,
// 0 frames, Frame Time <= 0, non-finite or extra numbers).
Motion load_bvh(const std::string& path);
// The same from the file's contents (`path` names it in errors).
Motion parse_bvh(std::string_view text, const std::string& path);

}  // namespace gatcore::character
