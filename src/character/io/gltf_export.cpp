#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>

#include "gatcore/character/io/gltf.hpp"
#include "gatcore/error.hpp"
#include "src/character/io/gltf_util.hpp"

namespace gatcore::character {

using gltf_util::append_accessor;

void save_gltf_with_weights(const std::string& source_path, const Character& ch, const SkinWeights& weights,
                            const std::string& out_path, int max_influences) {
  GATCORE_CHECK(max_influences >= 1 && max_influences <= 64, out_path, ": max_influences must be in [1, 64], got ",
                max_influences);
  // Influences are written in sets of 4 (JOINTS_n / WEIGHTS_n).
  const int sets = (max_influences + 3) / 4, K = 4 * sets;
  const std::int64_t nw = ch.mesh.num_vertices();
  GATCORE_CHECK(weights.num_vertices() == nw, out_path, ": ", weights.num_vertices(), " weight rows for ", nw,
                " vertices");
  const std::int32_t J = ch.skeleton.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(ch.joint_nodes.size()) == J, out_path,
                ": the character has no file node per joint (not loaded from a glTF file)");
  tinygltf::Model model = gltf_util::read_model(source_path);
  // Per welded vertex: its max_influences largest weights, renormalised
  // (padded with zero weights to a multiple of 4).
  std::vector<std::vector<std::pair<int, float>>> top(static_cast<std::size_t>(nw));
  for (std::int64_t v = 0; v < nw; ++v) {
    std::vector<std::pair<float, int>> l;
    for (std::int64_t k = weights.ptr[v]; k < weights.ptr[v + 1]; ++k) {
      GATCORE_CHECK(weights.joint[k] >= 0 && weights.joint[k] < J && std::isfinite(weights.weight[k]) &&
                        weights.weight[k] >= 0.0f,
                    out_path, ": vertex ", v, " has weight ", weights.weight[k], " on joint ", weights.joint[k]);
      if (weights.weight[k] > 0.0f) l.push_back({weights.weight[k], weights.joint[k]});
    }
    std::sort(l.begin(), l.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    l.resize(std::min<std::size_t>(l.size(), static_cast<std::size_t>(max_influences)));
    float sum = 0.0f;
    for (const auto& e : l) sum += e.first;
    GATCORE_CHECK(sum > 0.0f, out_path, ": vertex ", v, " has no positive weight");
    top[v].assign(static_cast<std::size_t>(K), std::pair{0, 0.0f});
    for (std::size_t k = 0; k < l.size(); ++k) top[v][k] = {l[k].second, l[k].first / sum};
  }
  for (const SourcePrimitive& sp : ch.primitives) {
    GATCORE_CHECK(sp.node >= 0 && sp.node < static_cast<int>(model.nodes.size()) && sp.mesh >= 0 &&
                      sp.mesh < static_cast<int>(model.meshes.size()),
                  source_path, ": does not match the character (node ", sp.node, ", mesh ", sp.mesh, ")");
    const int skin_id = model.nodes[sp.node].skin;
    GATCORE_CHECK(skin_id >= 0, source_path, ": node ", sp.node, " has no skin");
    tinygltf::Skin& skin = model.skins[skin_id];
    std::map<int, int> slot;  // skeleton joint -> index in skin.joints
    for (std::size_t k = 0; k < skin.joints.size(); ++k)
      for (std::int32_t j = 0; j < J; ++j)
        if (ch.joint_nodes[j] == skin.joints[k]) slot.emplace(j, static_cast<int>(k));
    const std::size_t before = skin.joints.size();
    std::vector<std::uint16_t> jv(K * sp.num_vertices);
    std::vector<float> wv(K * sp.num_vertices);
    for (std::int64_t i = 0; i < sp.num_vertices; ++i) {
      const auto& t = top[ch.welded_from_file[sp.first_vertex + i]];
      for (int k = 0; k < K; ++k) {
        int s = 0;
        if (t[k].second > 0.0f) {
          auto it = slot.find(t[k].first);
          if (it == slot.end()) {
            skin.joints.push_back(ch.joint_nodes[t[k].first]);
            it = slot.emplace(t[k].first, static_cast<int>(skin.joints.size()) - 1).first;
          }
          s = it->second;
        }
        GATCORE_CHECK(s < 65536, out_path, ": more than 65536 joints in a skin");
        jv[K * i + k] = static_cast<std::uint16_t>(s);
        wv[K * i + k] = t[k].second;
      }
    }
    if (skin.joints.size() != before) {
      // The skin's own matrices stay (they may be relative to this mesh, not
      // to the character's bind space); a joint new to it gets the
      // character's matrix taken back into this mesh's space.
      std::vector<float> ibm(16 * skin.joints.size());
      if (skin.inverseBindMatrices >= 0) {
        const std::vector<float> old = gltf_util::read_floats(model, skin.inverseBindMatrices, 16,
                                                              "skin " + std::to_string(skin_id) + " inverseBindMatrices",
                                                              source_path);
        GATCORE_CHECK(old.size() == 16 * before, source_path, ": skin ", skin_id, " has ", old.size() / 16,
                      " inverse bind matrices for ", before, " joints");
        std::copy(old.begin(), old.end(), ibm.begin());
      } else {
        for (std::size_t k = 0; k < before; ++k) {
          const Mat4 id = mat4_identity();
          std::copy(id.begin(), id.end(), ibm.begin() + 16 * k);
        }
      }
      for (std::size_t k = before; k < skin.joints.size(); ++k) {
        std::int32_t j = -1;
        for (std::int32_t q = 0; q < J; ++q)
          if (ch.joint_nodes[q] == skin.joints[k]) j = q;
        const Mat4 m = j >= 0 ? mul(ch.skeleton.inverse_bind[j], sp.to_bind) : mat4_identity();
        std::copy(m.begin(), m.end(), ibm.begin() + 16 * k);
      }
      skin.inverseBindMatrices = append_accessor(model, ibm.data(), ibm.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                 TINYGLTF_TYPE_MAT4, skin.joints.size());
    }
    auto& prim = model.meshes[sp.mesh].primitives.at(static_cast<std::size_t>(sp.primitive));
    for (int set = 0; prim.attributes.count("JOINTS_" + std::to_string(set)) ||
                      prim.attributes.count("WEIGHTS_" + std::to_string(set));
         ++set) {
      prim.attributes.erase("JOINTS_" + std::to_string(set));
      prim.attributes.erase("WEIGHTS_" + std::to_string(set));
    }
    // Set s holds influences [4s, 4s + 4) of every vertex.
    for (int set = 0; set < sets; ++set) {
      std::vector<std::uint16_t> js(4 * sp.num_vertices);
      std::vector<float> ws(4 * sp.num_vertices);
      for (std::int64_t i = 0; i < sp.num_vertices; ++i)
        for (int k = 0; k < 4; ++k) {
          js[4 * i + k] = jv[K * i + 4 * set + k];
          ws[4 * i + k] = wv[K * i + 4 * set + k];
        }
      prim.attributes["JOINTS_" + std::to_string(set)] =
          append_accessor(model, js.data(), js.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4,
                          static_cast<std::size_t>(sp.num_vertices));
      prim.attributes["WEIGHTS_" + std::to_string(set)] =
          append_accessor(model, ws.data(), ws.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4,
                          static_cast<std::size_t>(sp.num_vertices));
    }
  }
  gltf_util::write_model_atomic(model, out_path);
}

}  // namespace gatcore::character
