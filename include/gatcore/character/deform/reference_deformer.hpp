#pragma once
// The reference deformer: what DenseGATs learns to add on top of LBS. A small
// interface with three implementations:
// - Delta Mush on LBS (the default; deform.hpp), cheap, the earlier results;
// - ARAP driven by the skinned skeleton (arap.hpp), expensive and physically
//   motivated (tens of ms per frame);
// - file targets (target_frames.hpp): the frames a studio's own deformer
//   stack baked, for the poses of the motion that drove it.
// The built-in ones deform any pose; file targets exist only for their frames.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gatcore/character/deform/arap.hpp"
#include "gatcore/character/deform/deform.hpp"

namespace gatcore::character {

enum class ReferenceKind { delta_mush, arap, files };
const char* reference_kind_name(ReferenceKind k);  // "delta_mush", "arap", "files"
// Throws InvalidArgument naming `what` for an unknown name.
ReferenceKind parse_reference_kind(const std::string& name, const std::string& what);

// The reference deformer of a character: the target positions of a pose
// (not a deformer a model plays back: that is inference/corrective.hpp).
class ReferenceTargets {
 public:
  virtual ~ReferenceTargets() = default;
  virtual ReferenceKind kind() const = 0;
  // The target positions ([3 n], the prepared character's world frame) of a
  // pose whose LBS positions are `lbs_world`. `frame`: the file target's
  // frame for file targets (-1 for any other pose: file targets throw).
  virtual std::vector<float> deform(std::span<const float> lbs_world, std::int32_t frame) const = 0;
  // File targets: how many frames there are (0: any pose).
  virtual std::int32_t num_frames() const { return 0; }
};

std::shared_ptr<const ReferenceTargets> delta_mush_reference(const Mesh& mesh, const DeltaMushParams& params);
std::shared_ptr<const ReferenceTargets> arap_reference(const Mesh& mesh, const ArapParams& params);
// `frames`: [frames][3 n] target positions in the prepared character's world frame.
std::shared_ptr<const ReferenceTargets> file_reference(std::vector<std::vector<float>> frames, std::string source);

}  // namespace gatcore::character
