// Training-data augmentations (augment.hpp): each keeps the data consistent,
// changes what it says it changes and nothing else, and variants in a
// dataset stay with their source's split part through a file round trip.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "character_fixtures.hpp"
#include "gatcore/character/data/augment.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace {

Character humanoid(std::uint32_t seed = 3) {
  ProceduralOptions o;
  o.seed = seed;
  return procedural_character(o);
}

std::vector<std::map<std::int32_t, float>> rows(const SkinWeights& w) {
  std::vector<std::map<std::int32_t, float>> out(std::size_t(w.num_vertices()));
  for (std::int64_t v = 0; v < w.num_vertices(); ++v)
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) out[std::size_t(v)][w.joint[k]] = w.weight[k];
  return out;
}

std::int32_t dominant(const std::map<std::int32_t, float>& r) {
  return std::max_element(r.begin(), r.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;
}

Vec3 head(const Skeleton& s, std::int32_t j) { return mat4_translation(inverse(s.inverse_bind[std::size_t(j)])); }

// Every invariant a training character must keep: valid skeleton (parents
// before children) and mesh (ids, weights summing to 1), top-4, and the rest
// pose skinning the bind mesh onto itself (the procedural bind pose is its
// rest pose, so any inconsistency between rest, bind and mesh shows).
void check_consistent(const Character& c) {
  INFO(c.name);
  REQUIRE_NOTHROW(c.skeleton.validate("variant"));
  REQUIRE_NOTHROW(c.mesh.validate(c.skeleton.num_joints(), "variant"));
  CHECK(c.mesh.weights.max_influences() <= 4);
  for (std::int32_t j = 0; j < c.skeleton.num_joints(); ++j) CHECK(c.skeleton.parents[std::size_t(j)] < j);
  const auto m = skinning_matrices(c.skeleton, rest_pose(c.skeleton));
  const auto& w = c.mesh.weights;
  double scale = 0, worst = 0;
  for (std::int64_t v = 0; v < c.mesh.num_vertices(); ++v) {
    const Vec3 p{c.mesh.positions[3 * v], c.mesh.positions[3 * v + 1], c.mesh.positions[3 * v + 2]};
    Vec3 q{0, 0, 0};
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) {
      const Vec3 t = transform_point(m[std::size_t(w.joint[k])], p);
      for (int a = 0; a < 3; ++a) q[a] += w.weight[k] * t[a];
    }
    for (int a = 0; a < 3; ++a) {
      worst = std::max(worst, double(std::abs(q[a] - p[a])));
      scale = std::max(scale, double(std::abs(p[a])));
    }
  }
  CHECK(worst <= 1e-4 * std::max(1.0, scale));
  CHECK(c.welded_from_file.size() == std::size_t(c.mesh.num_vertices()));
}

// The mesh skinned in the skeleton's rest pose (the file's node transforms).
std::vector<float> rest_lbs(const Character& c) {
  const auto m = skinning_matrices(c.skeleton, rest_pose(c.skeleton));
  const auto& w = c.mesh.weights;
  std::vector<float> out(c.mesh.positions.size(), 0.0f);
  for (std::int64_t v = 0; v < c.mesh.num_vertices(); ++v) {
    const Vec3 p{c.mesh.positions[3 * v], c.mesh.positions[3 * v + 1], c.mesh.positions[3 * v + 2]};
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) {
      const Vec3 t = transform_point(m[std::size_t(w.joint[k])], p);
      for (int a = 0; a < 3; ++a) out[3 * std::size_t(v) + a] += w.weight[k] * t[a];
    }
  }
  return out;
}

}  // namespace

TEST_CASE("augment: kind names parse, unknown and repeated ones are errors", "[character][augment]") {
  CHECK(parse_augment_kinds("rigid,twist", "--augment") == std::vector<AugmentKind>{AugmentKind::rigid, AugmentKind::twist});
  CHECK(parse_augment_kinds("all", "x").size() == all_augment_kinds().size());
  for (AugmentKind k : all_augment_kinds()) CHECK(parse_augment_kinds(augment_kind_name(k), "x").front() == k);
  CHECK_THROWS_WITH(parse_augment_kinds("rigid,wobble", "--augment"),
                    Catch::Contains("--augment") && Catch::Contains("unknown augmentation 'wobble'") &&
                        Catch::Contains("z-up"));
  CHECK_THROWS_WITH(parse_augment_kinds("rigid,rigid", "--augment"), Catch::Contains("given twice"));
  CHECK_THROWS_WITH(parse_augment_kinds("", "--augment"), Catch::Contains("empty augmentation name"));
  const AugmentEntry e{{AugmentKind::split, AugmentKind::z_up}, 42, "procedural:humanoid:3"};
  const AugmentEntry back = parse_augment_entry(augment_entry(e));
  CHECK(augment_entry(e) == "augment:split+z-up:42:procedural:humanoid:3");
  CHECK(back.kinds == e.kinds);
  CHECK(back.seed == 42u);
  CHECK(back.source == e.source);
  CHECK_THROWS_WITH(parse_augment_entry("augment:split:-1:a.glb"), Catch::Contains("seed '-1'"));
  CHECK_THROWS_WITH(parse_augment_entry("augment:split:x.glb"), Catch::Contains("augment:KINDS:SEED:SOURCE"));
  CHECK_THROWS_WITH(parse_augment_entry("augment:bend:1:a.glb"), Catch::Contains("unknown augmentation 'bend'"));
}

TEST_CASE("augment: every kind keeps the data consistent, deterministically", "[character][augment]") {
  const Character c = humanoid();
  check_consistent(c);
  for (AugmentKind k : all_augment_kinds()) {
    INFO(augment_kind_name(k));
    const Character a = augment_character(c, {k}, 11), b = augment_character(c, {k}, 11);
    check_consistent(a);
    CHECK(a.mesh.positions == b.mesh.positions);
    CHECK(a.mesh.weights.weight == b.mesh.weights.weight);
    CHECK(a.skeleton.names == b.skeleton.names);
    CHECK(a.name.find("~aug11") != std::string::npos);
  }
  const Character all = augment_character(c, all_augment_kinds(), 5);
  check_consistent(all);
  CHECK(all.skeleton.num_joints() > c.skeleton.num_joints());
}

TEST_CASE("augment: a split bone's halves sum to the original, other bones keep theirs", "[character][augment]") {
  const Character c = humanoid();
  const RigMapping map = map_rig(c.skeleton);
  const std::int32_t arm = map.find("upperarm.l");
  REQUIRE(arm >= 0);
  const Character s = split_bone(c, arm, 0.4f, "arm_lower_half", true);
  check_consistent(s);
  REQUIRE(s.skeleton.num_joints() == c.skeleton.num_joints() + 1);
  CHECK(s.skeleton.names[std::size_t(arm + 1)] == "arm_lower_half");
  CHECK(s.skeleton.parents[std::size_t(arm + 1)] == arm);
  // The forearm now hangs from the new joint and stays where it was.
  const std::int32_t fore = map.find("forearm.l");
  CHECK(s.skeleton.parents[std::size_t(fore + 1)] == arm + 1);
  for (int a = 0; a < 3; ++a) CHECK(head(s.skeleton, fore + 1)[a] == Approx(head(c.skeleton, fore)[a]).margin(1e-5));
  const auto before = rows(c.mesh.weights), after = rows(s.mesh.weights);
  std::int64_t shared = 0, changed_dominant = 0, arm_vertices = 0;
  for (std::size_t v = 0; v < before.size(); ++v) {
    if (before[v].size() >= 4) continue;  // a top-4 cut may renormalise
    auto get = [](const std::map<std::int32_t, float>& r, std::int32_t j) {
      const auto it = r.find(j);
      return it == r.end() ? 0.0f : it->second;
    };
    CHECK(get(after[v], arm) + get(after[v], arm + 1) == Approx(get(before[v], arm)).margin(1e-5));
    shared += get(after[v], arm) > 0 && get(after[v], arm + 1) > 0;
    for (const auto& [j, w] : before[v])
      if (j != arm) CHECK(get(after[v], j > arm ? j + 1 : j) == Approx(w).margin(1e-6));
    // Dominant bone: the same apart from the split bone's two halves.
    const std::int32_t d0 = dominant(before[v]), d1 = dominant(after[v]);
    const std::int32_t d1_old = d1 == arm + 1 ? arm : d1 > arm ? d1 - 1 : d1;
    changed_dominant += d1_old != d0;
    arm_vertices += get(before[v], arm) > 0;
  }
  CHECK(changed_dominant == 0);
  CHECK(shared > 0);
  CHECK(arm_vertices > shared);  // the ramp is narrower than the bone
  REQUIRE(c.skeleton.children()[0].size() > 1);  // the pelvis: legs and spine
  CHECK_THROWS_WITH(split_bone(c, 0, 0.5f, "x", true), Catch::Contains("children"));
}

TEST_CASE("augment: a twist bone takes the distal weights and no children", "[character][augment]") {
  const Character c = humanoid();
  const Character t = augment_character(c, {AugmentKind::twist}, 1);
  check_consistent(t);
  CHECK(t.skeleton.num_joints() == c.skeleton.num_joints() + 6);
  const auto ch = t.skeleton.children();
  int twists = 0;
  for (std::int32_t j = 0; j < t.skeleton.num_joints(); ++j) {
    if (t.skeleton.names[std::size_t(j)].find("_twist_01") == std::string::npos) continue;
    ++twists;
    CHECK(ch[std::size_t(j)].empty());
    const std::int32_t base = t.skeleton.parents[std::size_t(j)];
    CHECK(t.skeleton.names[std::size_t(j)] == t.skeleton.names[std::size_t(base)] + "_twist_01");
    // Weights on base + twist equal the source bone's (top-4 permitting).
    const std::int32_t src = c.skeleton.find(t.skeleton.names[std::size_t(base)]);
    REQUIRE(src >= 0);
    const auto before = rows(c.mesh.weights), after = rows(t.mesh.weights);
    double total = 0;
    for (std::size_t v = 0; v < before.size(); ++v) {
      if (before[v].size() >= 4) continue;
      const float b = before[v].count(src) ? before[v].at(src) : 0.0f;
      const float a = (after[v].count(base) ? after[v].at(base) : 0.0f) + (after[v].count(j) ? after[v].at(j) : 0.0f);
      CHECK(a == Approx(b).margin(1e-5));
      total += after[v].count(j) ? after[v].at(j) : 0.0f;
    }
    CHECK(total > 0);
  }
  CHECK(twists == 6);
  // The rig layer still finds every body part (twist bones do not replace them).
  CHECK(map_rig(t.skeleton).humanoid());
}

TEST_CASE("augment: a merged child's weights are summed into its parent", "[character][augment]") {
  const Character c = humanoid();
  const RigMapping map = map_rig(c.skeleton);
  const std::int32_t fore = map.find("forearm.r"), arm = map.find("upperarm.r"), hand = map.find("hand.r");
  REQUIRE(fore >= 0);
  REQUIRE(c.skeleton.parents[std::size_t(fore)] == arm);
  const Character m = merge_bone(c, fore);
  check_consistent(m);
  REQUIRE(m.skeleton.num_joints() == c.skeleton.num_joints() - 1);
  CHECK(m.skeleton.find(c.skeleton.names[std::size_t(fore)]) < 0);
  const std::int32_t new_hand = hand > fore ? hand - 1 : hand;
  CHECK(m.skeleton.parents[std::size_t(new_hand)] == arm);
  for (int a = 0; a < 3; ++a) CHECK(head(m.skeleton, new_hand)[a] == Approx(head(c.skeleton, hand)[a]).margin(1e-5));
  const auto before = rows(c.mesh.weights), after = rows(m.mesh.weights);
  for (std::size_t v = 0; v < before.size(); ++v) {
    const float sum = (before[v].count(arm) ? before[v].at(arm) : 0.0f) + (before[v].count(fore) ? before[v].at(fore) : 0.0f);
    CHECK((after[v].count(arm) ? after[v].at(arm) : 0.0f) == Approx(sum).margin(1e-5));
  }
  CHECK_THROWS_WITH(merge_bone(c, 0), Catch::Contains("root"));
}

TEST_CASE("augment: rigid pieces end with exactly one influence, their dominant bone", "[character][augment]") {
  const Character c = humanoid();
  const Components comp = connected_components(c.mesh);
  REQUIRE(comp.count > 3);
  const auto before = rows(c.mesh.weights);
  const std::int32_t J = c.skeleton.num_joints();
  std::vector<std::vector<double>> sum(std::size_t(comp.count), std::vector<double>(std::size_t(J), 0.0));
  for (std::size_t v = 0; v < before.size(); ++v)
    for (const auto& [j, w] : before[v]) sum[std::size_t(comp.label[v])][std::size_t(j)] += w;
  // The threshold: the median piece's dominant share, so some pieces are above it and some below.
  std::vector<double> shares;
  for (const auto& s : sum) {
    double total = 0;
    for (double x : s) total += x;
    shares.push_back(*std::max_element(s.begin(), s.end()) / total);
  }
  std::sort(shares.begin(), shares.end());
  AugmentOptions o;
  o.rigid_pick = 0.0f;  // only the dominated pieces
  // Half-way between two pieces' shares, so rounding never decides.
  std::size_t mid = shares.size() / 2;
  while (mid + 1 < shares.size() && shares[mid + 1] - shares[mid] < 1e-3) ++mid;
  REQUIRE(mid + 1 < shares.size());
  o.rigid_share = float(0.5 * (shares[mid] + shares[mid + 1]));
  const Character r = rigid_parts(c, 9, o);
  check_consistent(r);
  const auto after = rows(r.mesh.weights);
  int rigid = 0, soft = 0;
  for (std::int32_t p = 0; p < comp.count; ++p) {
    const auto& s = sum[std::size_t(p)];
    const auto best = std::int32_t(std::max_element(s.begin(), s.end()) - s.begin());
    double total = 0;
    for (double x : s) total += x;
    const bool dominated = float(s[std::size_t(best)]) >= o.rigid_share * float(total);
    rigid += dominated;
    for (std::size_t v = 0; v < before.size(); ++v) {
      if (comp.label[v] != p) continue;
      if (dominated) {
        REQUIRE(after[v].size() == 1);
        CHECK(after[v].begin()->first == best);
        CHECK(after[v].begin()->second == 1.0f);
      } else {
        CHECK(after[v] == before[v]);
        soft += 1;
      }
    }
  }
  CHECK(rigid > 0);
  CHECK(soft > 0);
  // Picked pieces: with every piece picked and no size limit, all are rigid.
  o.rigid_pick = 1.0f;
  o.rigid_max_piece = 1.0f;
  const Character all = rigid_parts(c, 9, o);
  CHECK(all.mesh.weights.max_influences() == 1);
}

TEST_CASE("augment: decimation keeps surviving vertices' weights unchanged", "[character][augment]") {
  const Character c = humanoid();
  const Character d = decimate(c, 0.3f);
  check_consistent(d);
  CHECK(d.mesh.num_triangles() < c.mesh.num_triangles() * 6 / 10);
  CHECK(d.mesh.num_vertices() < c.mesh.num_vertices());
  std::map<std::array<float, 3>, std::vector<std::int64_t>> at;
  for (std::int64_t v = 0; v < c.mesh.num_vertices(); ++v)
    at[{c.mesh.positions[3 * v], c.mesh.positions[3 * v + 1], c.mesh.positions[3 * v + 2]}].push_back(v);
  const auto before = rows(c.mesh.weights), after = rows(d.mesh.weights);
  for (std::int64_t v = 0; v < d.mesh.num_vertices(); ++v) {
    const auto it = at.find({d.mesh.positions[3 * v], d.mesh.positions[3 * v + 1], d.mesh.positions[3 * v + 2]});
    REQUIRE(it != at.end());  // edge collapse moves no vertex
    bool same = false;
    for (std::int64_t o : it->second) same = same || before[std::size_t(o)] == after[std::size_t(v)];
    CHECK(same);
  }
}

TEST_CASE("augment: a remeshed vertex's weights lie within its source triangle's", "[character][augment]") {
  const Character c = humanoid();
  std::vector<std::int32_t> src;
  const Character r = remesh(c, 30.0f, {}, &src);
  check_consistent(r);
  CHECK(r.mesh.num_vertices() < c.mesh.num_vertices());
  REQUIRE(src.size() == std::size_t(r.mesh.num_vertices()));
  // Pieces never fuse: as many pieces or more (a thin one may vanish), never fewer by merging.
  CHECK(connected_components(r.mesh).count <= connected_components(c.mesh).count + 8);
  const auto before = rows(c.mesh.weights), after = rows(r.mesh.weights);
  std::int64_t checked = 0;
  for (std::int64_t v = 0; v < r.mesh.num_vertices(); ++v) {
    const std::int32_t t = src[std::size_t(v)];
    REQUIRE(t >= 0);
    std::set<std::int32_t> joints;
    for (int a = 0; a < 3; ++a)
      for (const auto& [j, w] : before[std::size_t(c.mesh.triangles[3 * t + a])]) joints.insert(j);
    if (joints.size() > 4) continue;  // a top-4 cut renormalises
    ++checked;
    for (std::int32_t j : joints) {
      float lo = 1, hi = 0;
      for (int a = 0; a < 3; ++a) {
        const auto& row = before[std::size_t(c.mesh.triangles[3 * t + a])];
        const float w = row.count(j) ? row.at(j) : 0.0f;
        lo = std::min(lo, w);
        hi = std::max(hi, w);
      }
      const float w = after[std::size_t(v)].count(j) ? after[std::size_t(v)].at(j) : 0.0f;
      CHECK(w >= lo - 1e-5f);
      CHECK(w <= hi + 1e-5f);
    }
    for (const auto& [j, w] : after[std::size_t(v)]) CHECK(joints.count(j) == 1);
  }
  CHECK(checked > r.mesh.num_vertices() / 2);
  // Boundaries: a new vertex's dominant bone is one of its source corners'
  // (a blend could in principle crown another bone; bounded at 2 %).
  std::int64_t off = 0;
  for (std::int64_t v = 0; v < r.mesh.num_vertices(); ++v) {
    bool corner = false;
    for (int a = 0; a < 3; ++a)
      corner = corner || dominant(before[std::size_t(c.mesh.triangles[3 * src[std::size_t(v)] + a])]) ==
                             dominant(after[std::size_t(v)]);
    off += !corner;
  }
  CHECK(off <= r.mesh.num_vertices() / 50);
}

TEST_CASE("augment: rotation, scale and Z-up move the joints and leave the weights", "[character][augment]") {
  const Character c = humanoid();
  for (AugmentKind k : {AugmentKind::rotate, AugmentKind::scale, AugmentKind::z_up}) {
    INFO(augment_kind_name(k));
    const Character a = augment_character(c, {k}, 21);
    check_consistent(a);
    CHECK(a.mesh.weights.joint == c.mesh.weights.joint);
    CHECK(a.mesh.weights.weight == c.mesh.weights.weight);
    CHECK(a.skeleton.names == c.skeleton.names);
    CHECK(a.mesh.positions != c.mesh.positions);
    // Joints move with the mesh: each joint's distance to vertex 0 scales uniformly.
    const Vec3 p0{c.mesh.positions[0], c.mesh.positions[1], c.mesh.positions[2]};
    const Vec3 q0{a.mesh.positions[0], a.mesh.positions[1], a.mesh.positions[2]};
    auto dist = [](const Vec3& x, const Vec3& y) {
      return std::sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) + (x[2] - y[2]) * (x[2] - y[2]));
    };
    const float ratio = dist(head(a.skeleton, 0), q0) / dist(head(c.skeleton, 0), p0);
    for (std::int32_t j = 1; j < c.skeleton.num_joints(); ++j)
      CHECK(dist(head(a.skeleton, j), q0) == Approx(ratio * dist(head(c.skeleton, j), p0)).epsilon(1e-3).margin(1e-5));
    if (k == AugmentKind::z_up) {  // the head is now above the pelvis along +Z
      const RigMapping map = map_rig(c.skeleton);
      const Vec3 h = head(a.skeleton, map.find("head")), p = head(a.skeleton, map.find("pelvis"));
      CHECK(h[2] - p[2] > 0.5f * std::abs(h[1] - p[1]));
    }
  }
  CHECK(augment_character(c, {AugmentKind::rotate}, 1).mesh.positions !=
        augment_character(c, {AugmentKind::rotate}, 2).mesh.positions);
}

TEST_CASE("augment: renamed skeletons map to the same canonical bones", "[character][augment]") {
  const Character c = humanoid();
  const RigMapping before = map_rig(c.skeleton);
  REQUIRE(before.humanoid());
  for (const std::string& conv : rename_conventions()) {
    INFO(conv);
    const Character r = rename_bones(c, conv);
    check_consistent(r);
    const RigMapping after = map_rig(r.skeleton);
    CHECK(after.body == before.body);
    CHECK(after.humanoid());
    int renamed = 0;
    for (std::size_t j = 0; j < c.skeleton.names.size(); ++j) renamed += r.skeleton.names[j] != c.skeleton.names[j];
    CHECK(renamed >= 12);
    CHECK(r.mesh.weights.weight == c.mesh.weights.weight);
  }
  CHECK_THROWS_WITH(rename_bones(c, "nope"), Catch::Contains("unknown convention 'nope'"));
}

TEST_CASE("augment: helper bones carry no weight and change no body part", "[character][augment]") {
  const Character c = humanoid();
  const Character h = add_helper_bones(c, 4);
  check_consistent(h);
  REQUIRE(h.skeleton.num_joints() > c.skeleton.num_joints());
  for (std::int32_t j : h.mesh.weights.joint) CHECK(j < c.skeleton.num_joints());
  CHECK(h.mesh.weights.weight == c.mesh.weights.weight);
  const RigMapping a = map_rig(c.skeleton), b = map_rig(h.skeleton);
  for (std::size_t j = 0; j < c.skeleton.names.size(); ++j) CHECK(b.body[j] == a.body[j]);
}

TEST_CASE("augment: chains get one bone more or fewer, boundaries elsewhere are kept", "[character][augment]") {
  const Character c = humanoid();
  int more = 0, fewer = 0;
  for (std::uint32_t seed = 0; seed < 12; ++seed) {
    const Character a = augment_character(c, {AugmentKind::chains}, seed);
    check_consistent(a);
    const int d = a.skeleton.num_joints() - c.skeleton.num_joints();
    CHECK(std::abs(d) == 1);
    more += d > 0;
    fewer += d < 0;
    // Dominant bone by name: changes only where a split bone, a merged bone
    // or the parent it went into was dominant.
    std::set<std::string> involved;
    for (std::int32_t j = 0; j < c.skeleton.num_joints(); ++j)
      if (a.skeleton.find(c.skeleton.names[std::size_t(j)]) < 0) {
        involved.insert(c.skeleton.names[std::size_t(j)]);
        involved.insert(c.skeleton.names[std::size_t(c.skeleton.parents[std::size_t(j)])]);
      }
    for (std::int32_t j = 0; j < a.skeleton.num_joints(); ++j)
      if (c.skeleton.find(a.skeleton.names[std::size_t(j)]) < 0) {
        involved.insert(a.skeleton.names[std::size_t(j)]);
        involved.insert(a.skeleton.names[std::size_t(a.skeleton.parents[std::size_t(j)])]);
      }
    CHECK(involved.size() == 2);
    const auto before = rows(c.mesh.weights), after = rows(a.mesh.weights);
    std::int64_t changed = 0;
    for (std::size_t v = 0; v < before.size(); ++v) {
      const std::string& b = c.skeleton.names[std::size_t(dominant(before[v]))];
      const std::string& n = a.skeleton.names[std::size_t(dominant(after[v]))];
      changed += b != n && !involved.count(b) && !involved.count(n);
    }
    CHECK(changed == 0);
  }
  CHECK(more > 0);
  CHECK(fewer > 0);
}

TEST_CASE("augment: dataset variants follow their source's split part and round-trip", "[character][augment][dataset]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "gatcore_test_augment_dataset";
  fs::remove_all(dir);
  fs::create_directories(dir / "women");
  // A "family" of file characters and procedural ones: the test family is held out.
  DatasetDescription s;
  s.augment.kinds = {AugmentKind::rigid, AugmentKind::split, AugmentKind::rotate};
  s.augment.copies = 2;
  s.augment.seed = 5;
  DatasetDescription d = describe_dataset(
      {"procedural:humanoid:1", "procedural:humanoid:2", "procedural:humanoid:3", "procedural:creature:4"}, {}, s);
  d.split = Split{{0, 3}, {1}, {2}};
  add_augmented_variants(d);
  REQUIRE(d.characters.size() == 12);
  std::set<std::string> held{"procedural:humanoid:2", "procedural:humanoid:3"};
  for (std::int32_t c : d.split.train) CHECK(held.count(augment_source(d.characters[std::size_t(c)])) == 0);
  CHECK(d.split.train.size() == 6);
  CHECK(d.split.validation.size() == 3);
  CHECK(d.split.test.size() == 3);
  for (std::int32_t c : d.split.test) CHECK(augment_source(d.characters[std::size_t(c)]) == "procedural:humanoid:3");
  // Same settings, same variants; another seed, other ones.
  DatasetDescription d2 = describe_dataset(
      {"procedural:humanoid:1", "procedural:humanoid:2", "procedural:humanoid:3", "procedural:creature:4"}, {}, s);
  d2.split = Split{{0, 3}, {1}, {2}};
  add_augmented_variants(d2);
  CHECK(d2.characters == d.characters);
  s.augment.seed = 6;
  DatasetDescription d3 = describe_dataset({"procedural:humanoid:1"}, {}, s);
  add_augmented_variants(d3);
  CHECK(d3.characters[1] != d.characters[4]);
  // Reports name a variant after its source's family folder and file.
  CHECK(dataset_character_name("/data/modular_women/Punk.glb") == "modular_women/Punk");
  CHECK(dataset_character_name(augment_entry({{AugmentKind::twist}, 9, "/data/modular_women/Punk.glb"})) ==
        "modular_women/Punk~aug9");
  CHECK(dataset_character_name("procedural:humanoid:3") == "procedural:humanoid:3");
  CHECK(dataset_character_name(d.characters[4]).rfind("procedural:humanoid:1~aug", 0) == 0);
  // A variant loads, named after its source.
  const Character v = load_dataset_character(d.characters[4]);
  CHECK(v.name.find("~aug") != std::string::npos);
  check_consistent(v);

  // File round trip, with a file source written relative to the dataset.
  d.characters.push_back(augment_entry({{AugmentKind::z_up}, 7, (dir / "women" / "Punk.glb").string()}));
  d.split.test.push_back(static_cast<std::int32_t>(d.characters.size() - 1));
  const std::string path = (dir / "set.json").string();
  save_dataset(path, d);
  {
    std::ifstream f(path);
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    CHECK(text.find("augment:z-up:7:women/Punk.glb") != std::string::npos);
    CHECK(text.find("\"copies\": 2") != std::string::npos);
  }
  const DatasetDescription back = load_dataset(path);
  CHECK(back.characters == d.characters);
  CHECK(back.split.train == d.split.train);
  CHECK(back.split.test == d.split.test);
  CHECK(back.augment.kinds == d.augment.kinds);
  CHECK(back.augment.copies == 2);
  CHECK(back.augment.seed == 5u);

  // A training variant of a held-out character is refused, in memory and in a file.
  DatasetDescription leak = d;
  leak.split.test.erase(std::find(leak.split.test.begin(), leak.split.test.end(), 9));
  leak.split.train.push_back(9);
  CHECK_THROWS_WITH(validate_dataset(leak, "leak"), Catch::Contains("trains, but procedural:humanoid:3 (its source, or a variant of it) is held out"));
  auto write = [&](const std::string& from, const std::string& to) {
    std::ifstream f(path);
    std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    std::ofstream((dir / "bad.json").string()) << text;
    return (dir / "bad.json").string();
  };
  CHECK_THROWS_WITH(load_dataset(write("\"copies\": 2", "\"copies\": -1")), Catch::Contains("augment.copies"));
  CHECK_THROWS_WITH(load_dataset(write("\"rotate\"", "\"spin\"")), Catch::Contains("unknown augmentation 'spin'"));
  CHECK_THROWS_WITH(load_dataset(write("augment:z-up:7:", "augment:z-up:x7:")), Catch::Contains("seed 'x7'"));
  DatasetDescription neg = d;
  neg.augment.copies = -1;
  CHECK_THROWS_WITH(add_augmented_variants(neg), Catch::Contains("augment.copies"));
  fs::remove_all(dir);
}

TEST_CASE("augment: a shared Quaternius character stays consistent under every kind", "[character][augment][data]") {
  const auto dir = charfix::data_dir();
  const auto punk = dir / "characters/quaternius/modular_women/Punk.glb";
  if (dir.empty() || !std::filesystem::exists(punk)) {
    WARN("SKIPPED: data not found (" << punk << ")");
    return;
  }
  const Character c = load_dataset_character(punk.string());
  const std::vector<float> rest = rest_lbs(c);
  float extent = 0;
  for (float x : c.mesh.positions) extent = std::max(extent, std::abs(x));
  for (AugmentKind k : all_augment_kinds()) {
    INFO(augment_kind_name(k));
    const Character a = augment_character(c, {k}, 3);
    REQUIRE_NOTHROW(a.skeleton.validate("variant"));
    REQUIRE_NOTHROW(a.mesh.validate(a.skeleton.num_joints(), "variant"));
    CHECK(a.mesh.weights.max_influences() <= 4);
    CHECK(a.name.find("modular_women/Punk~aug3") != std::string::npos);
    // Skeleton edits keep the rest pose's skinned mesh (merging a bone the
    // rest pose bends would not, so merge is left out).
    if (k == AugmentKind::split || k == AugmentKind::twist || k == AugmentKind::helpers || k == AugmentKind::rename ||
        k == AugmentKind::rigid) {
      const std::vector<float> got = rest_lbs(a);
      REQUIRE(got.size() == rest.size());
      float worst = 0;
      for (std::size_t i = 0; i < got.size(); ++i) worst = std::max(worst, std::abs(got[i] - rest[i]));
      // rigid changes weights: only where a piece bends in the rest pose.
      if (k != AugmentKind::rigid) CHECK(worst <= 1e-4f * std::max(1.0f, extent));
    }
    if (k == AugmentKind::rename) CHECK(map_rig(a.skeleton).body == map_rig(c.skeleton).body);
  }
}
