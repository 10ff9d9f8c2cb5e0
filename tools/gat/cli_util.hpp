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
// "COMMAND: warning: CHARACTER lacks ... (character_model.hpp). Name the
// matching joints with --alias JOINT=BONE, or REMEDY." on stderr when
// `character` (mapped by `m`) lacks bones all the model's training characters
// had (checkpoint `f` at `model_path`, bone columns `bones`); nothing otherwise.
void warn_unseen_absent_bones(const char* command, const gatcore::models::CheckpointFile& f,
                              const std::string& model_path, const std::string& character,
                              const gatcore::character::BoneMapping& m, const std::vector<std::string>& bones,
                              const char* remedy);

}  // namespace gat
