#include "gatcore/character/rig/super_skeleton.hpp"

#include <cctype>
#include <unordered_map>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

bool is_sep(char c) { return c == ' ' || c == '.' || c == '_' || c == '-'; }

}  // namespace

std::string normalise_bone_name(const std::string& name) {
  std::string s = name;
  const std::size_t cut = s.find_last_of(":|");
  if (cut != std::string::npos) s = s.substr(cut + 1);
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  char side = 0;
  // Suffix markers: ".l", "_l", " l", "-l" (and r).
  if (s.size() >= 2 && is_sep(s[s.size() - 2]) && (s.back() == 'l' || s.back() == 'r')) {
    side = s.back();
    s.resize(s.size() - 2);
  } else if (s.rfind("left", 0) == 0 && s.size() > 4) {
    side = 'l';
    s = s.substr(4);
  } else if (s.rfind("right", 0) == 0 && s.size() > 5) {
    side = 'r';
    s = s.substr(5);
  } else if (s.size() >= 2 && (s[0] == 'l' || s[0] == 'r') && is_sep(s[1])) {
    side = s[0];
    s = s.substr(2);
  }
  std::string out;
  for (char c : s)
    if (!is_sep(c)) out.push_back(c);
  if (side) {
    out.push_back('.');
    out.push_back(side);
  }
  return out;
}

BoneAliases BoneAliases::quaternius_women_to_men() {
  BoneAliases a;
  for (const char* side : {".l", ".r"})
    for (const char* finger : {"index", "middle", "ring", "pinky"})
      for (int k = 1; k <= 3; ++k)
        a.pairs.push_back({std::string(finger) + std::to_string(k) + side,
                           std::string(finger) + std::to_string(k + 1) + side});
  return a;
}

std::string BoneAliases::apply(const std::string& n) const {
  for (const auto& [from, to] : pairs)
    if (from == n) return to;
  return n;
}

SuperSkeleton build_super_skeleton(const std::vector<const Skeleton*>& skeletons,
                                   const std::vector<BoneAliases>& aliases) {
  GATCORE_CHECK(aliases.empty() || aliases.size() == skeletons.size(), "super skeleton: ", aliases.size(),
                " alias tables for ", skeletons.size(), " skeletons");
  const BoneAliases none;
  SuperSkeleton ss;
  std::unordered_map<std::string, std::int32_t> index;
  for (std::size_t c = 0; c < skeletons.size(); ++c) {
    const Skeleton& s = *skeletons[c];
    std::vector<std::int32_t> map(static_cast<std::size_t>(s.num_joints()));
    std::unordered_map<std::string, std::int32_t> seen;
    for (std::int32_t j = 0; j < s.num_joints(); ++j) {
      const std::string n = (aliases.empty() ? none : aliases[c]).apply(normalise_bone_name(s.names[j]));
      auto [it, fresh] = seen.emplace(n, j);
      GATCORE_CHECK(fresh, "super skeleton: joints '", s.names[it->second], "' and '", s.names[j], "' of skeleton ", c,
                    " both map to bone '", n, "'");
      auto [bi, added] = index.emplace(n, static_cast<std::int32_t>(ss.names.size()));
      if (added) ss.names.push_back(n);
      map[j] = bi->second;
    }
    ss.joint_to_bone.push_back(std::move(map));
  }
  for (const auto& map : ss.joint_to_bone) {
    std::vector<std::uint8_t> m(ss.names.size(), 0);
    for (std::int32_t b : map) m[b] = 1;
    ss.mask.push_back(std::move(m));
  }
  return ss;
}

std::vector<float> super_weights(const SkinWeights& w, const std::vector<std::int32_t>& joint_to_bone,
                                 std::int32_t num_bones) {
  const std::int64_t n = w.num_vertices();
  std::vector<float> out(static_cast<std::size_t>(n) * num_bones, 0.0f);
  for (std::int64_t v = 0; v < n; ++v)
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) {
      const std::int32_t j = w.joint[k];
      GATCORE_CHECK(j >= 0 && j < static_cast<std::int32_t>(joint_to_bone.size()), "super_weights: vertex ", v,
                    " is weighted to joint ", j, " of ", joint_to_bone.size());
      out[v * num_bones + joint_to_bone[j]] += w.weight[k];
    }
  return out;
}

}  // namespace gatcore::character
