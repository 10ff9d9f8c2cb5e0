#pragma once
// Training samples for the two models, generated on the fly, and the
// train / validation / test split by character.
//
// A sample is built from a PreparedCharacter (features/prepared_character.hpp)
// with the feature functions inference uses too
// (features/frame_features.hpp), plus what only training has: the Delta Mush
// target, vertex windows, the induced subgraph. Samples are in normalised
// coordinates (NormalisationStats).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <vector>

#include "gatcore/character/data/augment.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/deform/reference_deformer.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/character/rig/character.hpp"
#include "gatcore/character/rig/joint_limits.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::character {

// Features and targets are expressed in the character's root frame
// (frame_features.hpp). `root_motion` maps that frame back to the world.
struct DenseGatsSample {
  Tensor features;  // [m, 6 + J]: posed position, posed normal, distance to each joint (normalised, root frame)
  Tensor distortion;  // [m, 3 S]: detail distortion at the character's S scales (normalised, root frame); S = 0: empty
  Tensor target;    // [m, 3]: reference deformer - LBS displacement (normalised units, root frame)
  Tensor lbs;       // [m, 3]: LBS positions (normalised, world frame)
  Mat4 root_motion = mat4_identity();  // the root's current world transform times its rest inverse
  CsrGraph graph;   // subgraph of the mesh graph induced by `vertices`
  std::vector<std::int32_t> vertices;
  std::int32_t character = -1, pose = -1;
};

// One pose of one character; `count` consecutive vertices from `first`
// (count <= 0 or >= n: the whole mesh). Normals and Delta Mush are computed
// on the whole mesh, then restricted. The target is the character's
// reference deformer (pc.reference) on the LBS mesh; `target_frame` >= 0 is
// the frame of file targets (pose = pc.target_poses[target_frame]).
// `with_target` false (inference) skips it and leaves `target` undefined.
DenseGatsSample make_densegats_sample(const PreparedCharacter& pc, const Pose& pose, std::int64_t first,
                                      std::int64_t count, bool with_target = true, std::int32_t target_frame = -1);
// The sample's model input and root-to-world offsets (frame_features.hpp).
inline Tensor densegats_model_features(const Tensor& bone_features, const DenseGatsSample& s) {
  return densegats_model_features(bone_features, s.distortion);
}
inline Vec3 root_offset_to_world(const DenseGatsSample& s, const Vec3& offset) {
  return root_offset_to_world(s.root_motion, offset);
}

struct NeuroSkinningSample {
  Tensor features;  // [m, 6 + J]: rest position, rest normal, distance to each bone segment (normalised)
  Tensor weights;   // [m, J] ground-truth skin weights
  CsrGraph graph;
  std::vector<std::int32_t> vertices;
  std::int32_t character = -1;
};
// `vertices` empty: the whole mesh.
NeuroSkinningSample make_neuroskinning_sample(const PreparedCharacter& pc, std::span<const std::int32_t> vertices = {});

struct Split {
  std::vector<std::int32_t> train, validation, test;  // character indices
};
// Shuffles characters with `seed` (std::mt19937 integers, portable) and cuts
// off round(fraction * n) for validation and test (at least one each when
// the fraction is positive and n >= 3). Never splits a character's poses.
Split split_by_character(std::int32_t num_characters, float validation, float test, std::uint32_t seed);

struct SampleTask {
  std::int32_t character = 0, pose_index = 0;
  std::int32_t target_frame = -1;  // file targets: the frame (make_densegats_sample)
  Pose pose;
  std::int64_t first = 0, count = 0;
};
// Generates the samples of `tasks` in a oneTBB pipeline (at most `tokens` in
// flight, computed in parallel, handed to `sink` in task order on the calling
// thread's pipeline) so a trainer consuming them keeps being fed. OpenMP is
// disabled inside the pipeline's tasks (SerialRegion).
void stream_densegats_samples(const std::vector<PreparedCharacter>& characters, const std::vector<SampleTask>& tasks,
                              const std::function<void(DenseGatsSample&&)>& sink, int tokens = 4);

}  // namespace gatcore::character

namespace gatcore::character {

// Per-frame targets a character carries from files (io/target_frames.hpp):
// the frames of `file` are the targets of the poses of `motion` at motion
// frame first_frame + k * step for target frame k (step: the .pc2 sample
// rate; 1 for a glTF). Such a character trains and evaluates on those frames
// only (no random poses: there is no target for them).
struct FileTargetSource {
  std::int32_t character = -1;  // index into DatasetDescription::characters
  std::string file;             // .pc2, comma-separated .pc2 (one per mesh) or .glb / .gltf
  std::string motion;           // a BVH retargeted onto the character, or "clip:NAME" (the file's own)
  std::string animation;        // glTF: the morph animation (empty: "deform" or the only one)
  std::optional<double> first_frame;  // unset: the file's (.pc2 start frame; glTF 0)
};

// Augmented variants per character (augment.hpp): `copies` variants of every
// source character, each applying a seeded non-empty subset of `kinds`.
struct DatasetAugmentation {
  std::vector<AugmentKind> kinds;  // empty: no variants
  int copies = 1;
  std::uint32_t seed = 0;
};
inline constexpr int kMaxAugmentCopies = 1000;

// What `gat dataset build` writes (JSON): the sources and every setting the
// samples depend on, so a trainer regenerates identical samples on the fly.
struct DatasetDescription {
  std::vector<std::string> characters;  // file paths, or "procedural:humanoid:SEED" / "procedural:creature:SEED"
  std::vector<std::string> motions;     // BVH files, retargeted onto every character (CMU joint names)
  int random_poses = 32;                // per character per epoch
  float pose_angle = 0.5f;              // uniform_limits(+-pose_angle) around the bind pose, unless:
  std::optional<JointLimitTable> joint_limits;  // per-joint limits for the random poses (recorded in full)
  int motion_stride = 4;                // every k-th motion frame
  std::uint32_t seed = 0;
  ReferenceKind reference = ReferenceKind::delta_mush;  // for characters without file targets
  DeltaMushParams delta_mush;           // the reference deformer's parameters (Delta Mush)
  ArapParams arap;                      // (ARAP)
  std::vector<FileTargetSource> targets;  // characters with file targets (at most one source each)
  std::int64_t subsample = 1000;        // DenseGATs: consecutive vertices per sample (<= 0: whole mesh)
  std::vector<int> distortion_scales;   // DenseGATs: detail-distortion columns (empty: the paper's features only)
  float validation = 0.1f, test = 0.1f;
  Split split;                          // by character, from seed
  // Variants are entries "augment:KINDS:SEED:SOURCE" (augment_entry) after
  // the sources; these settings record how they were made.
  DatasetAugmentation augment;
};

// The ranges every dataset description must be in, whether from `gat
// dataset build` or a dataset file (validate_dataset).
struct DatasetLimits {
  double max_random_poses = 1e6;  // per character per epoch
  double max_pose_angle = 3.2;    // radians
  double max_motion_stride = 1e6;
  double max_subsample = 1e9;
  double max_fraction = 0.9;      // validation, test and their sum
  double max_dm_iterations = 10000;
  double min_dm_step = 1e-6;
};
// Throws InvalidArgument naming `where`, the field and the value for any
// field out of range (DatasetLimits), a bad distortion scale, a split index
// out of range or listed twice (within or across train / validation / test),
// augment.copies out of [0, kMaxAugmentCopies], a malformed variant entry, or
// a training variant whose source is a validation or test character.
void validate_dataset(const DatasetDescription& d, const std::string& where);

// Fills the split from the fractions and the seed (validated).
DatasetDescription describe_dataset(std::vector<std::string> characters, std::vector<std::string> motions,
                                    const DatasetDescription& settings = {});
// Appends d.augment.copies variants of every character that is not itself a
// variant, named after it (augment_entry; each variant's kinds and seed drawn
// from d.augment.seed, the source and the copy), and puts each in its
// source's split part, so a character held out (validation, test; a whole
// family in a leave-one-family-out split) keeps its variants out of training.
// No kinds or no copies: unchanged. Call it after the split is final.
void add_augmented_variants(DatasetDescription& d);
// The entry a variant was made from (the entry itself when not a variant).
std::string augment_source(const std::string& entry);
// A character's name in reports: "FOLDER/STEM" for a file (its family's
// folder, e.g. modular_women/Punk), the entry for a procedural one, and the
// source's name + "~augSEED" for a variant (modular_women/Punk~aug123).
std::string dataset_character_name(const std::string& entry);

// File entries are written relative to the dataset file's directory and
// resolved against it on load (procedural entries unchanged).
void save_dataset(const std::string& path, const DatasetDescription& d);
// Throws InvalidArgument naming the file and the field for bad files.
DatasetDescription load_dataset(const std::string& path);
// A character by its dataset entry (a file, a procedural spec, or a variant
// "augment:KINDS:SEED:SOURCE" of one).
Character load_dataset_character(const std::string& entry);

// The DenseGATs tasks of one epoch for the given characters (indices into
// d.characters; `prepared` and `motions` are the loaded ones, all of them):
// random poses and strided motion frames, each with a random vertex window;
// deterministic per (seed, epoch).
std::vector<SampleTask> dataset_tasks(const DatasetDescription& d, const std::vector<PreparedCharacter>& prepared,
                                      const std::vector<Motion>& motions,
                                      std::span<const std::int32_t> characters, int epoch);

}  // namespace gatcore::character
