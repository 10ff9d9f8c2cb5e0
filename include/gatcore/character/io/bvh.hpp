#pragma once
// BVH motion capture import (through assimp).
#include <string>

#include "gatcore/character/rig/motion.hpp"

namespace gatcore::character {

// Reads a BVH file, one pose per file frame (clip.fps = 1 / Frame Time).
// Throws InvalidArgument naming the file and the problem (unreadable,
// truncated, no motion, non-finite values).
Motion load_bvh(const std::string& path);

}  // namespace gatcore::character
