#include "gatcore/character/features/prepared_character.hpp"

#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

Character to_world(const Character& ch, const Mat4& bind_to_world) {
  Character w = ch;
  for (std::int64_t v = 0; v < w.mesh.num_vertices(); ++v) {
    const Vec3 p = transform_point(bind_to_world, {ch.mesh.positions[3 * v], ch.mesh.positions[3 * v + 1],
                                                   ch.mesh.positions[3 * v + 2]});
    for (int c = 0; c < 3; ++c) w.mesh.positions[3 * v + c] = p[c];
  }
  const Mat4 inv = inverse(bind_to_world);
  for (auto& ibm : w.skeleton.inverse_bind) ibm = mul(ibm, inv);
  return w;
}

PreparedCharacter prepare_character(const Character& ch, const DeltaMushParams& params,
                                    std::span<const int> distortion_scales) {
  const NormalisationStats n0 = compute_normalisation(ch);
  PreparedCharacter pc;
  pc.character = to_world(ch, n0.bind_to_world);
  pc.normalisation = compute_normalisation(pc.character);
  pc.normalisation.bind_to_world = mat4_identity();  // already world (the rest-pose matrix is ~identity now)
  pc.delta_mush = delta_mush_bind(pc.character.mesh, params);
  pc.mesh_graph = graph_from_triangles(pc.character.mesh.num_vertices(), pc.character.mesh.triangles);
  pc.rest = bind_pose(pc.character.skeleton);
  set_distortion_scales(pc, distortion_scales);
  return pc;
}

void set_distortion_scales(PreparedCharacter& pc, std::span<const int> scales) {
  pc.rest_details = laplacian_details(pc.delta_mush, pc.character.mesh.positions, scales);  // checks the scales
  pc.distortion_scales.assign(scales.begin(), scales.end());
}

DetailHalves detail_halves(const PreparedCharacter& pc, std::span<const Mat4> skinning,
                           std::span<const float> lbs_root, const Mat4& to_root) {
  DetailHalves h;
  h.posed = laplacian_details(pc.delta_mush, lbs_root, pc.distortion_scales);
  for (const std::vector<float>& rest : pc.rest_details) {
    // World -> root frame, normalised: the root motion is rigid and the
    // normalisation a uniform scale, so vectors turn by to_root's rotation
    // and scale by normalisation.scale.
    std::vector<float> r = skin_vectors(pc.character.mesh, skinning, rest);
    for (std::size_t v = 0; v < r.size() / 3; ++v) {
      const float* a = &r[3 * v];
      const float x = a[0], y = a[1], z = a[2];
      for (int c = 0; c < 3; ++c)
        r[3 * v + c] = (to_root[c] * x + to_root[4 + c] * y + to_root[8 + c] * z) * pc.normalisation.scale;
    }
    h.rest.push_back(std::move(r));
  }
  return h;
}

std::int32_t root_motion_joint(const PreparedCharacter& pc) {
  const Skeleton& sk = pc.character.skeleton;
  std::int32_t j = pc.normalisation.origin_joint >= 0 && pc.normalisation.origin_joint < sk.num_joints() ? pc.normalisation.origin_joint : 0;
  for (std::int32_t guard = 0; sk.parents[std::size_t(j)] >= 0 && guard < sk.num_joints(); ++guard)
    j = sk.parents[std::size_t(j)];
  return j;
}

}  // namespace gatcore::character
