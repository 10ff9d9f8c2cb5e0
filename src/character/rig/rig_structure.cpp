// The structural fallback of map_rig: when joint names do not say which
// joint is a thigh or an upper arm, the rest pose usually does. A humanoid
// stands upright: exactly two leaf chains reach the ground (the legs, their
// lowest common ancestor is the pelvis), two more end well above it far to
// the sides (the arms, meeting at the chest), and the highest leaf is the
// head. Knees and elbows are found by where they sit along their chain, and
// the thigh and upper arm as the joints before them, so names that say the
// joint a bone starts at, or the bone itself, or nothing, read the same.
#include <algorithm>
#include <cmath>
#include <map>

#include "src/character/rig/rig_tables.hpp"

namespace gatcore::character::rig_detail {

namespace {

float dist(const Vec3& a, const Vec3& b) {
  const float x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return std::sqrt(x * x + y * y + z * z);
}

std::vector<std::int32_t> path_to(const Skeleton& s, std::int32_t j) {
  std::vector<std::int32_t> p;
  for (; j >= 0; j = s.parents[j]) p.push_back(j);
  std::reverse(p.begin(), p.end());
  return p;
}

std::int32_t common_ancestor(const Skeleton& s, std::int32_t a, std::int32_t b) {
  const auto pa = path_to(s, a), pb = path_to(s, b);
  std::int32_t c = -1;
  for (std::size_t i = 0; i < pa.size() && i < pb.size() && pa[i] == pb[i]; ++i) c = pa[i];
  return c;
}

// The joints strictly below `from` on the way to `to` (and `to`), helpers skipped.
std::vector<std::int32_t> chain(const Skeleton& s, const RigMapping& m, std::int32_t from, std::int32_t to) {
  std::vector<std::int32_t> c;
  bool below = from < 0;
  for (std::int32_t j : path_to(s, to)) {
    if (below && m.role[j] != JointRole::helper) c.push_back(j);
    below = below || j == from;
  }
  return c;
}

}  // namespace

void propose_by_structure(const Skeleton& s, const std::vector<Vec3>& pos, RigMapping& m) {
  const std::int32_t J = s.num_joints();
  auto set = [&](std::int32_t j, const std::string& part) {
    if (j < 0 || m.role[j] != JointRole::other) return;
    if (!is_chain_part(part) && m.find(part) >= 0) return;
    m.role[j] = JointRole::body;
    m.body[j] = part;
    m.by_structure[j] = 1;
  };
  // Leaves among the joints that are not helpers.
  std::vector<int> kids(static_cast<std::size_t>(J), 0);
  float lo = 1e30f, hi = -1e30f;
  for (std::int32_t j = 0; j < J; ++j) {
    if (m.role[j] == JointRole::helper) continue;
    lo = std::min(lo, pos[j][1]);
    hi = std::max(hi, pos[j][1]);
    if (s.parents[j] >= 0) ++kids[s.parents[j]];
  }
  const float H = hi - lo;
  if (!(H > 0.0f)) return;
  std::vector<std::int32_t> low, leaves;
  std::int32_t head = -1;
  for (std::int32_t j = 0; j < J; ++j) {
    if (m.role[j] == JointRole::helper || kids[j] > 0) continue;
    leaves.push_back(j);
    if (pos[j][1] < lo + 0.15f * H) low.push_back(j);
    if (head < 0 || pos[j][1] > pos[head][1]) head = j;
  }
  // Exactly two feet: four (a quadruped) or eight (a spider) are not a humanoid.
  if (low.size() != 2 || head < 0) return;
  // Facing: the toes point forward (else +Z); the character's left is
  // up x forward (+X when it faces +Z). The lateral axis is the line between
  // the feet, so rigs facing +X (CesiumMan) read as well as +Z ones.
  Vec3 across = {pos[low[0]][0] - pos[low[1]][0], 0.0f, pos[low[0]][2] - pos[low[1]][2]};
  const float width = std::sqrt(across[0] * across[0] + across[2] * across[2]);
  if (width < 0.05f * H) return;
  for (float& c : across) c /= width;
  float toes = 0.0f;  // along forward = across x up = (-z, 0, x)
  for (std::int32_t f : low)
    if (s.parents[f] >= 0)
      toes += -across[2] * (pos[f][0] - pos[s.parents[f]][0]) + across[0] * (pos[f][2] - pos[s.parents[f]][2]);
  const bool low0_left = toes != 0.0f ? toes > 0.0f : across[0] >= 0.0f;
  const Vec3 left = low0_left ? across : Vec3{-across[0], 0.0f, -across[2]};
  auto side_of = [&](std::int32_t j, std::int32_t from) {
    return (pos[j][0] - pos[from][0]) * left[0] + (pos[j][2] - pos[from][2]) * left[2];
  };
  const std::int32_t foot_l = low0_left ? low[0] : low[1], foot_r = low0_left ? low[1] : low[0];
  const std::int32_t pelvis = common_ancestor(s, foot_l, foot_r);
  if (pelvis < 0 || pos[head][1] < pos[pelvis][1] + 0.2f * H) return;  // not upright
  // Hands: leaves above the knees, far to each side of the head.
  std::int32_t hand_l = -1, hand_r = -1;
  for (std::int32_t j : leaves) {
    if (j == head || pos[j][1] < lo + 0.3f * H) continue;
    const float side = side_of(j, head);
    if (side > 0.15f * H && (hand_l < 0 || side > side_of(hand_l, head))) hand_l = j;
    if (side < -0.15f * H && (hand_r < 0 || side < side_of(hand_r, head))) hand_r = j;
  }
  if (hand_l < 0 || hand_r < 0) return;
  const std::int32_t chest = common_ancestor(s, hand_l, hand_r);
  if (chest < 0) return;

  set(pelvis, "pelvis");
  // Spine: from the pelvis up to the chest; neck: from there to the head.
  const auto axis = chain(s, m, pelvis, head);
  bool past_chest = std::find(axis.begin(), axis.end(), chest) == axis.end();
  for (std::int32_t j : axis) {
    if (j == head) set(j, "head");
    else set(j, past_chest ? "neck" : "spine");
    past_chest = past_chest || j == chest;
  }
  for (int side = 0; side < 2; ++side) {
    const std::string sfx = side == 0 ? ".l" : ".r";
    // Leg: the knee is the joint nearest half way down from the pelvis to
    // the ground; the thigh the last joint before it at least 0.6 of a shin
    // away (so a hip-joint offset from the pelvis, as CMU rigs have, or a
    // twist segment is passed over); the ankle the first joint after the
    // knee near the ground, the toe after it.
    const auto leg = chain(s, m, pelvis, side == 0 ? foot_l : foot_r);
    if (leg.size() >= 2) {
      const float mid = 0.5f * (pos[pelvis][1] + lo);
      std::size_t knee = 1;
      for (std::size_t i = 1; i < leg.size(); ++i)
        if (std::abs(pos[leg[i]][1] - mid) < std::abs(pos[leg[knee]][1] - mid)) knee = i;
      std::size_t ankle = leg.size();
      for (std::size_t i = knee + 1; i < leg.size() && ankle == leg.size(); ++i)
        if (pos[leg[i]][1] < lo + 0.1f * H) ankle = i;
      const float shin = dist(pos[leg[knee]], pos[leg[ankle < leg.size() ? ankle : leg.size() - 1]]);
      std::size_t thigh = knee - 1;
      for (std::size_t i = knee; i-- > 0;)
        if (dist(pos[leg[i]], pos[leg[knee]]) >= 0.6f * shin) {
          thigh = i;
          break;
        }
      set(leg[thigh], "thigh" + sfx);
      set(leg[knee], "shin" + sfx);
      if (ankle < leg.size()) {
        set(leg[ankle], "foot" + sfx);
        if (ankle + 1 < leg.size()) set(leg[ankle + 1], "toe" + sfx);
      }
    }
    // Arm: a short first link off the chest is the clavicle; the hand is
    // where the fingers split (or the last joint); the elbow half way.
    const auto arm = chain(s, m, chest, side == 0 ? hand_l : hand_r);
    if (arm.size() < 3) continue;
    std::size_t upper = 0;
    if (arm.size() >= 4 && (dist(pos[arm[0]], pos[arm[1]]) < 0.6f * dist(pos[arm[1]], pos[arm[2]]) ||
                            std::abs(side_of(arm[0], chest)) < 0.05f * H))
      upper = 1;
    std::size_t hand = arm.size() - 1;
    for (std::size_t i = upper + 2; i < arm.size(); ++i)
      if (kids[arm[i]] >= 2) {
        hand = i;
        break;
      }
    const float reach = dist(pos[arm[upper]], pos[arm[hand]]);
    std::size_t elbow = upper + 1;
    for (std::size_t i = upper + 1; i < hand; ++i)
      if (std::abs(dist(pos[arm[upper]], pos[arm[i]]) - 0.55f * reach) <
          std::abs(dist(pos[arm[upper]], pos[arm[elbow]]) - 0.55f * reach))
        elbow = i;
    if (elbow >= hand) continue;
    if (upper == 1) set(arm[0], "clavicle" + sfx);
    set(arm[upper], "upperarm" + sfx);
    set(arm[elbow], "forearm" + sfx);
    set(arm[hand], "hand" + sfx);
  }
  // Renumber the spine and neck chains with what the names gave.
  for (const char* base : {"spine", "neck"}) {
    std::vector<std::pair<std::size_t, std::int32_t>> links;
    for (std::int32_t j = 0; j < J; ++j)
      if (m.role[j] == JointRole::body && m.body[j].rfind(base, 0) == 0) links.push_back({path_to(s, j).size(), j});
    std::stable_sort(links.begin(), links.end());
    for (std::size_t i = 0; i < links.size(); ++i) m.body[links[i].second] = base + std::to_string(i + 1);
  }
}

}  // namespace gatcore::character::rig_detail
