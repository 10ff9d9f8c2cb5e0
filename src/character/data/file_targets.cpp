#include "gatcore/character/data/file_targets.hpp"

#include <cmath>

#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/io/target_frames.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

FileTargetSummary attach_file_targets(PreparedCharacter& pc, const Character& file_character,
                                      const FileTargetSource& src, const std::string& what) {
  const Character& ch = pc.character;
  GATCORE_CHECK(file_character.mesh.num_vertices() == ch.mesh.num_vertices(), what, ": the character file has ",
                file_character.mesh.num_vertices(), " vertices, the prepared character ", ch.mesh.num_vertices());
  TargetFrames t = read_target_frames(file_character, src.file, src.animation);
  GATCORE_CHECK(!t.positions.empty(), what, ": ", src.file, " has no frames");

  // The driving motion's poses.
  std::vector<Pose> poses;
  std::string motion_name = src.motion;
  if (src.motion == "clip" || src.motion.rfind("clip:", 0) == 0) {
    const std::string name = src.motion.size() > 5 ? src.motion.substr(5) : std::string();
    const Clip* clip = nullptr;
    for (const Clip& c : file_character.clips)
      if (name.empty() ? file_character.clips.size() == 1 : c.name == name) clip = &c;
    GATCORE_CHECK(clip, what, ": ", src.motion, ": ", file_character.name, " has ", file_character.clips.size(),
                  " animations", name.empty() ? " (name one: clip:NAME)" : ", none named '" + name + "'");
    poses = clip->frames;
  } else {
    GATCORE_CHECK(!src.motion.empty(), what, ": no driving motion for ", src.file, " (a BVH, or clip:NAME)");
    poses = retarget(load_motion(src.motion), ch.skeleton, mat4_identity()).frames;
  }
  GATCORE_CHECK(!poses.empty(), what, ": ", motion_name, " has no frames");

  FileTargetSummary s;
  s.frames = static_cast<std::int32_t>(t.positions.size());
  s.first_frame = src.first_frame ? *src.first_frame : t.start_frame;
  s.step = t.frame_step;
  s.motion_frames = static_cast<std::int64_t>(poses.size());
  const double height = 1.0 / double(pc.normalisation.scale);
  pc.target_poses.clear();
  for (std::int32_t k = 0; k < s.frames; ++k) {
    const double m = s.first_frame + double(k) * s.step;
    const double r = std::round(m);
    GATCORE_CHECK(std::abs(m - r) < 1e-3 && r >= 0 && r < double(poses.size()), what, ": target frame ", k, " of ",
                  src.file, " is motion frame ", m, " (first frame ", s.first_frame, ", step ", s.step, "); ",
                  motion_name, " has frames 0..", poses.size() - 1);
    const Pose& pose = poses[std::size_t(r)];
    const std::vector<float> lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, pose));
    const std::vector<float>& tp = t.positions[std::size_t(k)];
    double sum = 0;
    for (std::size_t v = 0; v < lbs.size() / 3; ++v) {
      double d = 0;
      for (int c = 0; c < 3; ++c) d += (double(tp[3 * v + c]) - lbs[3 * v + c]) * (double(tp[3 * v + c]) - lbs[3 * v + c]);
      d = std::sqrt(d);
      sum += d;
      s.max_to_lbs = std::max(s.max_to_lbs, d);
    }
    const double mean = sum / double(std::max<std::size_t>(1, lbs.size() / 3));
    GATCORE_CHECK(mean <= 0.1 * height, what, ": target frame ", k, " of ", src.file, " is on average ", mean,
                  " units from LBS of motion frame ", r, " of ", motion_name, " (the character is ", height,
                  " tall): not that pose's deformation (wrong motion, frame map, up axis or units?)");
    s.mean_to_lbs += mean / double(s.frames);
    pc.target_poses.push_back(pose);
  }
  pc.reference = file_reference(std::move(t.positions), src.file);
  return s;
}

}  // namespace gatcore::character
