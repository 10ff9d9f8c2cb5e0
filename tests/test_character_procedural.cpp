// The embedded procedural character generator.
#include <catch2/catch.hpp>

#include <cmath>

#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/rig/motion.hpp"

using namespace gatcore::character;

TEST_CASE("procedural characters are deterministic per seed", "[character][procedural]") {
  for (auto kind : {ProceduralKind::humanoid, ProceduralKind::creature}) {
    ProceduralOptions o;
    o.kind = kind;
    o.seed = 3;
    const Character a = procedural_character(o), b = procedural_character(o);
    CHECK(a.mesh.positions == b.mesh.positions);
    CHECK(a.mesh.triangles == b.mesh.triangles);
    CHECK(a.mesh.weights.weight == b.mesh.weights.weight);
    CHECK(a.skeleton.names == b.skeleton.names);
    o.seed = 4;
    const Character c = procedural_character(o);
    CHECK(c.mesh.positions != a.mesh.positions);
  }
}

TEST_CASE("procedural characters are valid, grounded, skinnable rigs with garments", "[character][procedural]") {
  int skirts = 0;
  for (std::uint32_t seed = 0; seed < 6; ++seed)
    for (auto kind : {ProceduralKind::humanoid, ProceduralKind::creature}) {
      ProceduralOptions o;
      o.kind = kind;
      o.seed = seed;
      const Character ch = procedural_character(o);
      INFO(ch.name);
      ch.skeleton.validate();
      ch.mesh.validate(ch.skeleton.num_joints());
      const Components comp = connected_components(ch.mesh);
      if (kind == ProceduralKind::humanoid) {
        CHECK(ch.skeleton.num_joints() == 19);
        // torso + 2 arms + 2 legs + 2 sleeves + (skirt | 2 trouser legs)
        CHECK((comp.count == 8 || comp.count == 9));
        skirts += comp.count == 8;
        CHECK(ch.skeleton.find("UpperArm.L") >= 0);
      } else {
        CHECK(ch.skeleton.num_joints() == 19);
        CHECK(comp.count == 6);  // body, tail, 4 legs
      }
      float lo = 1e9f, hi = -1e9f;
      for (std::size_t v = 0; v < ch.mesh.positions.size() / 3; ++v) {
        lo = std::min(lo, ch.mesh.positions[3 * v + 1]);
        hi = std::max(hi, ch.mesh.positions[3 * v + 1]);
      }
      CHECK(lo == Approx(0.0f).margin(1e-5));
      CHECK(hi > 0.4f);
      // Bind pose == rest pose; LBS of it is the mesh.
      const auto S = skinning_matrices(ch.skeleton, rest_pose(ch.skeleton));
      const auto p = linear_blend_skinning(ch.mesh, S);
      float err = 0.0f;
      for (std::size_t i = 0; i < p.size(); ++i) err = std::max(err, std::abs(p[i] - ch.mesh.positions[i]));
      CHECK(err < 1e-5f);
      // Every joint but the hips carries weight, blends exist.
      CHECK(ch.mesh.weights.max_influences() >= 2);
      // A random pose deforms without NaNs; features and kNN build.
      std::mt19937 rng(seed);
      const Pose pose = random_pose(ch.skeleton, rest_pose(ch.skeleton), uniform_limits(ch.skeleton, 0.5f), rng);
      const auto posed = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, pose));
      for (float x : posed) REQUIRE(std::isfinite(x));
      const auto g = geodesic_knn(ch.mesh.positions, ch.mesh.triangles, 8);
      CHECK(g.num_nodes == ch.mesh.num_vertices());
    }
  CHECK(skirts > 0);
  CHECK(skirts < 6);
}
