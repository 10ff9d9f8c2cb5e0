// The per-frame features (features/frame_features.hpp) that the corrective
// deformer computes without a training sample: bitwise the columns of
// make_densegats_sample, and bitwise the computation the sample builder did
// before the two were split (written out here as the reference).
#include <catch2/catch.hpp>

#include <random>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/character/rig/motion.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

void check_same_bits(const Tensor& a, const Tensor& b, std::int64_t row_offset = 0) {
  REQUIRE(a.defined() == b.defined());
  if (!a.defined()) return;
  REQUIRE(a.cols() == b.cols());
  REQUIRE(a.rows() + row_offset <= b.rows());
  std::int64_t differ = 0;
  for (std::int64_t i = 0; i < a.rows(); ++i)
    for (std::int64_t c = 0; c < a.cols(); ++c) differ += a.at(i, c) != b.at(row_offset + i, c);
  CHECK(differ == 0);
}

// A bent pose whose root also moved and turned (root-frame features).
Pose bent_and_moved(const PreparedCharacter& pc, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Pose p = random_pose(pc.character.skeleton, pc.rest, uniform_limits(pc.character.skeleton, 0.8f), rng);
  Transform& t = p.local[std::size_t(root_motion_joint(pc))];
  t.rotation = quat_normalize(quat_mul(quat_from_axis_angle({0.2f, 1.0f, 0.1f}, 1.1f), t.rotation));
  t.translation[0] += 0.4f;
  t.translation[2] -= 0.9f;
  return p;
}

struct Reference {
  Tensor features, distortion, target, lbs;
};

// make_densegats_sample as it was before the per-frame features were split
// out of it (vertices [first, first + m)).
Reference reference_sample(const PreparedCharacter& pc, const Pose& pose, std::int64_t first, std::int64_t m) {
  const Character& ch = pc.character;
  const std::vector<Mat4> g = global_transforms(ch.skeleton, pose);
  std::vector<Mat4> skin(g.size());
  for (std::size_t j = 0; j < g.size(); ++j) skin[j] = mul(g[j], ch.skeleton.inverse_bind[j]);
  const std::vector<float> lbs_world = linear_blend_skinning(ch.mesh, skin);
  const std::vector<float> lbs = apply_normalisation(pc.normalisation, lbs_world);
  const std::int32_t r = root_motion_joint(pc);
  const std::vector<Mat4> g_rest = global_transforms(ch.skeleton, pc.rest);
  Transform motion = to_transform(mul(g[std::size_t(r)], inverse(g_rest[std::size_t(r)])));
  motion.scale = {1.0f, 1.0f, 1.0f};
  const Mat4 to_root = inverse(to_matrix(motion));
  auto in_root = [&](const std::vector<float>& w) {
    std::vector<float> out(w.size());
    for (std::size_t v = 0; v < w.size() / 3; ++v) {
      const Vec3 q = transform_point(to_root, {w[3 * v], w[3 * v + 1], w[3 * v + 2]});
      for (int c = 0; c < 3; ++c) out[3 * v + c] = q[std::size_t(c)];
    }
    return apply_normalisation(pc.normalisation, out);
  };
  const std::vector<float> lbs_root = in_root(lbs_world);
  const std::vector<float> mush_root = in_root(delta_mush_apply(pc.delta_mush, lbs_world));
  const std::vector<float> normals = vertex_normals(lbs_root, ch.mesh.triangles);
  std::vector<Vec3> joints = joint_positions(g);
  for (Vec3& j : joints) j = apply_normalisation(pc.normalisation, transform_point(to_root, j));
  Reference out;
  std::vector<float> p(3 * m), n(3 * m);
  out.target = Tensor::empty(m, 3);
  out.lbs = Tensor::empty(m, 3);
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = first + i;
      p[3 * i + c] = lbs_root[3 * v + c];
      n[3 * i + c] = normals[3 * v + c];
      out.lbs.at(i, c) = lbs[3 * v + c];
      out.target.at(i, c) = mush_root[3 * v + c] - lbs_root[3 * v + c];
    }
  out.features = densegats_features(p, n, joints);
  if (!pc.distortion_scales.empty()) {
    const DetailHalves h = detail_halves(pc, skin, lbs_root, to_root);
    const std::int64_t S = static_cast<std::int64_t>(h.posed.size());
    out.distortion = Tensor::empty(m, 3 * S);
    for (std::int64_t k = 0; k < S; ++k)
      for (std::int64_t i = 0; i < m; ++i)
        for (int c = 0; c < 3; ++c) {
          const std::size_t e = std::size_t(3 * (first + i) + c);
          out.distortion.at(i, 3 * k + c) = h.rest[std::size_t(k)][e] - h.posed[std::size_t(k)][e];
        }
  }
  return out;
}

}  // namespace

TEST_CASE("per-frame features: bitwise the training sample's columns", "[character][features]") {
  ProceduralOptions o;
  o.seed = 3;
  for (const std::vector<int>& scales : {std::vector<int>{}, std::vector<int>{2, 8}}) {
    const PreparedCharacter pc = prepare_character(procedural_character(o), DeltaMushParams{10, 0.5f}, scales);
    const std::int64_t n = pc.character.mesh.num_vertices();
    const Pose pose = bent_and_moved(pc, 4);
    const PosedFrame f = pose_frame(pc, pose);
    const std::vector<std::int32_t> all = all_vertices(n);
    const Tensor features = densegats_frame_features(f, all), distortion = distortion_frame_features(pc, f, all);
    REQUIRE(features.rows() == n);
    CHECK(distortion.defined() == !scales.empty());

    // What deform_frame computes == the whole-mesh training sample's inputs.
    const DenseGatsSample whole = make_densegats_sample(pc, pose, 0, 0, /*with_target=*/false);
    check_same_bits(features, whole.features);
    check_same_bits(distortion, whole.distortion);
    check_same_bits(densegats_model_features(features, distortion), densegats_model_features(whole.features, whole));
    CHECK(f.root_motion == whole.root_motion);

    // A vertex window, with its target, == the computation before the split.
    const std::int64_t first = 37, m = 300;
    const DenseGatsSample s = make_densegats_sample(pc, pose, first, m);
    const Reference ref = reference_sample(pc, pose, first, m);
    check_same_bits(s.features, ref.features);
    check_same_bits(s.distortion, ref.distortion);
    check_same_bits(s.target, ref.target);
    check_same_bits(s.lbs, ref.lbs);
    check_same_bits(s.features, features, first);
    const Vec3 d{0.1f, -0.2f, 0.3f};
    CHECK(root_offset_to_world(f.root_motion, d) == root_offset_to_world(s, d));
  }
}

TEST_CASE("per-frame features: vertices outside the mesh are an error", "[character][features]") {
  const PreparedCharacter pc = prepare_character(procedural_character({}), DeltaMushParams{0, 0.5f}, std::vector{2});
  const PosedFrame f = pose_frame(pc, pc.rest);
  const std::vector<std::int32_t> bad{0, static_cast<std::int32_t>(pc.character.mesh.num_vertices())};
  CHECK_THROWS_WITH(densegats_frame_features(f, bad), Catch::Contains("outside the mesh"));
  CHECK_THROWS_WITH(distortion_frame_features(pc, f, bad), Catch::Contains("outside the mesh"));
  CHECK_THROWS_WITH(neuroskinning_rest_features(pc, bad), Catch::Contains("outside the mesh"));
}

TEST_CASE("NeuroSkinning rest features: bitwise the training sample's", "[character][features]") {
  ProceduralOptions o;
  o.kind = ProceduralKind::creature;
  const PreparedCharacter pc = prepare_character(procedural_character(o));
  const NeuroSkinningSample s = make_neuroskinning_sample(pc);
  check_same_bits(neuroskinning_rest_features(pc, all_vertices(pc.character.mesh.num_vertices())), s.features);
}
