// BVH import through assimp (Debian's libassimp-dev): it parses the
// hierarchy, channels and Euler orders and hands back one key per frame.
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "gatcore/character/io/bvh.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

Mat4 to_mat4(const aiMatrix4x4& m) {
  // aiMatrix4x4 is row-major (a1..a4 the first row).
  return {m.a1, m.b1, m.c1, m.d1, m.a2, m.b2, m.c2, m.d2, m.a3, m.b3, m.c3, m.d3, m.a4, m.b4, m.c4, m.d4};
}

}  // namespace

Motion load_bvh(const std::string& path) {
  {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    GATCORE_CHECK(f != nullptr, path, ": cannot open file");
    std::fclose(f);
  }
  Assimp::Importer imp;
  const aiScene* scene = imp.ReadFile(path, 0);
  if (!scene || !scene->mRootNode) {
    std::string err = imp.GetErrorString();
    throw InvalidArgument(detail::cat(path, ": not a readable BVH file: ", err.empty() ? "unknown error" : err));
  }
  if (scene->mNumAnimations == 0 || scene->mAnimations[0]->mNumChannels == 0)
    throw InvalidArgument(detail::cat(path, ": no motion (no animated joints)"));
  const aiAnimation* anim = scene->mAnimations[0];
  std::map<std::string, const aiNodeAnim*> channel;
  for (unsigned c = 0; c < anim->mNumChannels; ++c) channel[anim->mChannels[c]->mNodeName.C_Str()] = anim->mChannels[c];

  Motion m;
  m.name = path;
  Skeleton& s = m.skeleton;
  std::vector<const aiNodeAnim*> chan;
  std::vector<Mat4> rest_global;
  // Preorder walk; joints are the animated nodes (end sites are not).
  struct Item {
    const aiNode* node;
    int parent;
    Mat4 parent_global;
  };
  std::vector<Item> stack{{scene->mRootNode, -1, mat4_identity()}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const Mat4 local = to_mat4(it.node->mTransformation);
    const Mat4 global = mul(it.parent_global, local);
    int self = it.parent;
    auto ch = channel.find(it.node->mName.C_Str());
    if (ch != channel.end()) {
      self = s.num_joints();
      s.names.push_back(it.node->mName.C_Str());
      s.parents.push_back(it.parent);
      s.rest_local.push_back(to_transform(local));
      s.root_parent.push_back(it.parent < 0 ? it.parent_global : mat4_identity());
      s.inverse_bind.push_back(inverse(global));
      chan.push_back(ch->second);
    }
    for (unsigned c = it.node->mNumChildren; c-- > 0;) stack.push_back({it.node->mChildren[c], self, global});
  }
  GATCORE_CHECK(s.num_joints() > 0, path, ": no motion (no animated joints)");
  s.validate(path.c_str());

  std::size_t frames = 0;
  for (const aiNodeAnim* c : chan) frames = std::max<std::size_t>({frames, c->mNumPositionKeys, c->mNumRotationKeys});
  GATCORE_CHECK(frames > 0, path, ": the motion has no frames");
  const double tps = anim->mTicksPerSecond > 0.0 ? anim->mTicksPerSecond : 30.0;
  m.clip.name = path.substr(path.find_last_of('/') + 1);
  m.clip.fps = static_cast<float>(tps);
  m.clip.frames.resize(frames);
  for (std::size_t f = 0; f < frames; ++f) {
    Pose& p = m.clip.frames[f];
    p.local = s.rest_local;
    for (std::int32_t j = 0; j < s.num_joints(); ++j) {
      const aiNodeAnim* c = chan[j];
      if (c->mNumPositionKeys > 0) {
        const aiVector3D& v = c->mPositionKeys[std::min<std::size_t>(f, c->mNumPositionKeys - 1)].mValue;
        p.local[j].translation = {v.x, v.y, v.z};
      }
      if (c->mNumRotationKeys > 0) {
        const aiQuaternion& q = c->mRotationKeys[std::min<std::size_t>(f, c->mNumRotationKeys - 1)].mValue;
        p.local[j].rotation = quat_normalize({q.x, q.y, q.z, q.w});
      }
      for (float x : p.local[j].translation)
        GATCORE_CHECK(std::isfinite(x), path, ": frame ", f, " joint '", s.names[j], "' has a non-finite position");
      for (float x : p.local[j].rotation)
        GATCORE_CHECK(std::isfinite(x), path, ": frame ", f, " joint '", s.names[j], "' has a non-finite rotation");
    }
  }
  return m;
}

}  // namespace gatcore::character
