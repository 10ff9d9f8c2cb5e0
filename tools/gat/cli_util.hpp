#pragma once
// Small helpers shared by the character commands (predict-weights, deform).
#include <string>
#include <vector>

#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/tensor.hpp"

namespace gat {

// ".glb" / ".gltf" (any case).
bool is_gltf_path(const std::string& path);
// Parses --device's value (cpu, vulkan, auto) and initialises Vulkan if asked;
// throws InvalidArgument for anything else.
gatcore::Device device_from_flag(const std::string& value, const char* command);
std::string device_label(gatcore::Device d);
// "JOINT=BONE": both normalised (normalise_bone_name) and added to `aliases`.
void add_alias(gatcore::character::BoneAliases& aliases, const std::string& spec);
// A non-negative integer in [lo, hi]; throws naming the flag.
long parse_int(const std::string& flag, const std::string& value, long lo, long hi);
// "COMMAND: WARNING. Name the matching joints with --alias JOINT=BONE, or
// REMEDY." on stderr, WARNING the runtime's absent_bones_warning (a character
// lacking bones all the model's training characters had); nothing when it is "".
void warn_absent_bones(const char* command, const std::string& warning, const char* remedy);

}  // namespace gat
