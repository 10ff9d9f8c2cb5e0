// FBX (and other assimp formats) character import.
//
// Containment: assimp's importers are not hardened against hostile files
// (its BVH importer, no longer used, had a heap-use-after-free).
// A user's file is therefore first parsed by assimp in a forked child
// process (probe_in_child): a crash, a sanitizer report, an abort or a hang
// (timeout) there ends the child, not gatcore, and the file is refused with
// a message naming it. Only a file the child parsed cleanly is parsed again
// in this process (the parse is deterministic). BVH files are read by
// gatcore's own reader (io/bvh.cpp) and never reach assimp.
#include <sys/wait.h>
#include <unistd.h>

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "gatcore/character/io/import.hpp"
#include "gatcore/error.hpp"
#include "src/character/rig/weld.hpp"

namespace gatcore::character {

namespace {

Mat4 to_mat4(const aiMatrix4x4& m) {
  return {m.a1, m.b1, m.c1, m.d1, m.a2, m.b2, m.c2, m.d2, m.a3, m.b3, m.c3, m.d3, m.a4, m.b4, m.c4, m.d4};
}

template <class Key>
std::size_t key_before(const Key* keys, unsigned n, double t) {
  std::size_t k = 0;
  while (k + 1 < n && keys[k + 1].mTime <= t) ++k;
  return k;
}

// The keys around time t and the linear blend between them (u = 0 before
// the first key and after the last: the nearest key holds).
struct KeyBlend {
  std::size_t k0, k1;
  float u;
};
template <class Key>
KeyBlend key_blend(const Key* keys, unsigned n, double t) {
  const std::size_t k = key_before(keys, n, t);
  const std::size_t k1 = std::min<std::size_t>(k + 1, n - 1);
  const double t0 = keys[k].mTime, t1 = keys[k1].mTime;
  return {k, k1, t1 > t0 ? static_cast<float>(std::clamp((t - t0) / (t1 - t0), 0.0, 1.0)) : 0.0f};
}
Vec3 lerp_keys(const aiVectorKey* keys, const KeyBlend& b) {
  const aiVector3D a0 = keys[b.k0].mValue, a1 = keys[b.k1].mValue;
  return {a0.x + b.u * (a1.x - a0.x), a0.y + b.u * (a1.y - a0.y), a0.z + b.u * (a1.z - a0.z)};
}

constexpr unsigned kReadFlags = aiProcess_Triangulate;
constexpr unsigned kProbeSeconds = 300;

void configure(Assimp::Importer& imp) { imp.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false); }

// Parses `path` with assimp in a child process. Returns normally when the
// child parsed it; throws InvalidArgument with assimp's error when it refused
// the file, or naming the crash / timeout.
void probe_in_child(const std::string& path) {
  int fds[2];
  GATCORE_CHECK(::pipe(fds) == 0, path, ": cannot create a pipe for the import check");
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw InvalidArgument(detail::cat(path, ": cannot fork the import check process"));
  }
  if (pid == 0) {
    ::close(fds[0]);
    ::alarm(kProbeSeconds);
    Assimp::Importer imp;
    configure(imp);
    const aiScene* scene = imp.ReadFile(path, kReadFlags);
    if (scene && scene->mRootNode) ::_exit(0);
    const std::string err = imp.GetErrorString();
    if (::write(fds[1], err.data(), err.size()) < 0) ::_exit(4);
    ::_exit(3);
  }
  ::close(fds[1]);
  std::string err;
  char buf[512];
  for (;;) {
    const ::ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n > 0) err.append(buf, std::size_t(n));
    else if (n == 0 || errno != EINTR) break;
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 3)
    throw InvalidArgument(detail::cat(path, ": not a readable character file: ", err.empty() ? "unknown error" : err));
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM)
    throw InvalidArgument(detail::cat(path, ": the assimp importer did not finish within ", kProbeSeconds,
                                      " s; refusing the file"));
  throw InvalidArgument(detail::cat(path, ": the assimp importer failed on this file (",
                                    WIFSIGNALED(status) ? "signal " : "exit status ",
                                    WIFSIGNALED(status) ? WTERMSIG(status) : WEXITSTATUS(status),
                                    "); refusing it (a malformed or unsupported file)"));
}

}  // namespace

Character load_assimp_character(const std::string& path, const ImportOptions& opt) {
  {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    GATCORE_CHECK(f != nullptr, path, ": cannot open file");
    std::fclose(f);
  }
  {
    std::string ext = path.substr(std::min(path.size(), path.find_last_of('.')));
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    GATCORE_CHECK(ext != ".bvh", path, ": a BVH file holds a motion, not a character (read it with load_bvh)");
  }
  probe_in_child(path);
  Assimp::Importer imp;
  configure(imp);
  const aiScene* scene = imp.ReadFile(path, kReadFlags);
  auto fail = [&](const auto&... parts) -> void { throw InvalidArgument(detail::cat(path, ": ", parts...)); };
  if (!scene || !scene->mRootNode) {
    const std::string err = imp.GetErrorString();
    fail("not a readable character file: ", err.empty() ? "unknown error" : err);
  }
  // Nodes in preorder with parents.
  std::vector<const aiNode*> nodes;
  std::vector<int> parent;
  std::map<std::string, int> by_name;
  {
    std::vector<std::pair<const aiNode*, int>> stack{{scene->mRootNode, -1}};
    while (!stack.empty()) {
      auto [n, p] = stack.back();
      stack.pop_back();
      const int id = static_cast<int>(nodes.size());
      nodes.push_back(n);
      parent.push_back(p);
      by_name.emplace(n->mName.C_Str(), id);
      for (unsigned c = n->mNumChildren; c-- > 0;) stack.push_back({n->mChildren[c], id});
    }
  }
  const int N = static_cast<int>(nodes.size());
  std::vector<Mat4> global(N);
  for (int i = 0; i < N; ++i) {
    const Mat4 l = to_mat4(nodes[i]->mTransformation);
    global[i] = parent[i] >= 0 ? mul(global[parent[i]], l) : l;
  }
  std::vector<char> is_bone(N, 0);
  bool any_bone = false;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
    for (unsigned b = 0; b < scene->mMeshes[m]->mNumBones; ++b) {
      const aiBone* bone = scene->mMeshes[m]->mBones[b];
      auto it = by_name.find(bone->mName.C_Str());
      if (it == by_name.end()) fail("mesh ", m, " bone '", bone->mName.C_Str(), "' has no node in the hierarchy");
      is_bone[it->second] = 1;
      any_bone = true;
    }
  // Without skins (an animation exported without its mesh, read as a motion
  // by request) the skeleton is the animated nodes and the nodes between them.
  const bool no_skin = !any_bone;
  if (no_skin && opt.allow_no_skin)
    for (unsigned ai = 0; ai < scene->mNumAnimations; ++ai)
      for (unsigned c = 0; c < scene->mAnimations[ai]->mNumChannels; ++c)
        if (const auto it = by_name.find(scene->mAnimations[ai]->mChannels[c]->mNodeName.C_Str()); it != by_name.end()) {
          is_bone[it->second] = 1;
          any_bone = true;
        }
  if (!any_bone) fail(no_skin && opt.allow_no_skin ? "no skin: no mesh has bones and no node is animated"
                                                   : "no skin: no mesh has bones");
  std::vector<char> in_skel = is_bone;
  for (int n = 0; n < N; ++n) {
    if (!is_bone[n]) continue;
    std::vector<int> chain;
    int last = -1;
    for (int x = parent[n]; x >= 0; x = parent[x]) {
      chain.push_back(x);
      if (is_bone[x]) last = static_cast<int>(chain.size());
    }
    for (int i = 0; i < last; ++i) in_skel[chain[i]] = 1;
  }
  Character ch;
  ch.name = path;
  Skeleton& sk = ch.skeleton;
  std::vector<int> joint_of(N, -1);
  for (int n = 0; n < N; ++n) {  // preorder: parents first
    if (!in_skel[n]) continue;
    joint_of[n] = sk.num_joints();
    sk.names.push_back(nodes[n]->mName.length ? nodes[n]->mName.C_Str() : "node" + std::to_string(n));
    const int p = parent[n];
    sk.parents.push_back(p >= 0 && in_skel[p] ? joint_of[p] : -1);
    sk.rest_local.push_back(to_transform(to_mat4(nodes[n]->mTransformation)));
    sk.root_parent.push_back(p >= 0 && !in_skel[p] ? global[p] : mat4_identity());
    sk.inverse_bind.push_back(inverse(global[n]));
    ch.joint_nodes.push_back(n);  // preorder index of the assimp node
  }
  std::vector<char> has_ibm(static_cast<std::size_t>(sk.num_joints()), 0);

  std::vector<float> pos;
  std::vector<std::vector<std::pair<int, float>>> infl;
  std::vector<std::int32_t> tris;
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* mesh = scene->mMeshes[mi];
    if (mesh->mNumBones == 0) continue;  // unskinned props are not part of the character
    const std::string what = "mesh '" + std::string(mesh->mName.C_Str()) + "' (" + std::to_string(mi) + ")";
    // This mesh's bind space -> the character's (fixed by the first mesh):
    // through a bone whose inverse bind matrix is already known, if any.
    Mat4 to_common = mat4_identity();
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const Mat4 off = to_mat4(mesh->mBones[b]->mOffsetMatrix);
      for (float x : off)
        if (!std::isfinite(x)) fail(what, " bone '", mesh->mBones[b]->mName.C_Str(), "' has a non-finite offset matrix");
    }
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const int j = joint_of[by_name[mesh->mBones[b]->mName.C_Str()]];
      if (has_ibm[j]) {
        to_common = mul(inverse(sk.inverse_bind[j]), to_mat4(mesh->mBones[b]->mOffsetMatrix));
        break;
      }
    }
    const Mat4 from_common = inverse(to_common);
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const int j = joint_of[by_name[mesh->mBones[b]->mName.C_Str()]];
      if (has_ibm[j]) continue;
      sk.inverse_bind[j] = mul(to_mat4(mesh->mBones[b]->mOffsetMatrix), from_common);
      has_ibm[j] = 1;
    }
    const std::int64_t base = static_cast<std::int64_t>(pos.size() / 3);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        fail(what, " vertex ", v, " has a non-finite position");
      const Vec3 q = transform_point(to_common, {p.x, p.y, p.z});
      pos.insert(pos.end(), q.begin(), q.end());
    }
    infl.resize(infl.size() + mesh->mNumVertices);
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const aiBone* bone = mesh->mBones[b];
      const int j = joint_of[by_name[bone->mName.C_Str()]];
      for (unsigned k = 0; k < bone->mNumWeights; ++k) {
        const aiVertexWeight& w = bone->mWeights[k];
        if (w.mVertexId >= mesh->mNumVertices)
          fail(what, " bone '", sk.names[j], "' weights vertex ", w.mVertexId, " of ", mesh->mNumVertices);
        if (!std::isfinite(w.mWeight) || w.mWeight < 0.0f)
          fail(what, " bone '", sk.names[j], "' has weight ", w.mWeight, " on vertex ", w.mVertexId);
        if (w.mWeight > 0.0f) infl[base + w.mVertexId].push_back({j, w.mWeight});
      }
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points / lines
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= mesh->mNumVertices) fail(what, " face ", f, " references vertex ", face.mIndices[c]);
        tris.push_back(static_cast<std::int32_t>(base + face.mIndices[c]));
      }
    }
    ch.primitives.push_back({static_cast<std::int32_t>(mi), 0, -1,
                             mesh->mName.length ? mesh->mName.C_Str() : "mesh" + std::to_string(mi), base,
                             static_cast<std::int64_t>(mesh->mNumVertices), to_common});
  }
  for (std::size_t v = 0; v < infl.size(); ++v)
    if (infl[v].empty()) fail("file vertex ", v, " has no non-zero skin weight");
  // Merge duplicate (joint) entries of a vertex.
  for (auto& l : infl) {
    std::sort(l.begin(), l.end());
    std::vector<std::pair<int, float>> m;
    for (const auto& e : l) {
      if (!m.empty() && m.back().first == e.first) m.back().second += e.second;
      else m.push_back(e);
    }
    l.swap(m);
  }
  sk.validate(path.c_str());
  if (!no_skin) {
    weld_into(ch, pos, infl, tris, opt.weld_tolerance);
    ch.mesh.validate(sk.num_joints(), path.c_str());
  }

  if (opt.load_clips) {
    GATCORE_CHECK(opt.clip_fps > 0.0f, "clip_fps must be positive, got ", opt.clip_fps);
    for (unsigned ai = 0; ai < scene->mNumAnimations; ++ai) {
      const aiAnimation* a = scene->mAnimations[ai];
      const double tps = a->mTicksPerSecond > 0.0 ? a->mTicksPerSecond : 25.0;
      std::vector<std::pair<int, const aiNodeAnim*>> chans;
      for (unsigned c = 0; c < a->mNumChannels; ++c) {
        auto it = by_name.find(a->mChannels[c]->mNodeName.C_Str());
        if (it != by_name.end() && joint_of[it->second] >= 0) chans.push_back({joint_of[it->second], a->mChannels[c]});
      }
      if (chans.empty()) continue;
      Clip clip;
      clip.name = a->mName.length ? a->mName.C_Str() : "animation" + std::to_string(ai);
      clip.fps = opt.clip_fps;
      const double duration = a->mDuration / tps;
      const int frames = clip_frame_count(duration, opt.clip_fps, sk.num_joints(), path + ": animation '" + clip.name + "'");
      for (int f = 0; f < frames; ++f) {
        const double t = f / static_cast<double>(opt.clip_fps) * tps;
        Pose p = rest_pose(sk);
        for (const auto& [j, c] : chans) {
          Transform& x = p.local[j];
          if (c->mNumPositionKeys)
            x.translation = lerp_keys(c->mPositionKeys, key_blend(c->mPositionKeys, c->mNumPositionKeys, t));
          if (c->mNumRotationKeys) {
            const KeyBlend b = key_blend(c->mRotationKeys, c->mNumRotationKeys, t);
            const aiQuaternion q0 = c->mRotationKeys[b.k0].mValue, q1 = c->mRotationKeys[b.k1].mValue;
            x.rotation = quat_slerp({q0.x, q0.y, q0.z, q0.w}, {q1.x, q1.y, q1.z, q1.w}, b.u);
          }
          if (c->mNumScalingKeys)
            x.scale = lerp_keys(c->mScalingKeys, key_blend(c->mScalingKeys, c->mNumScalingKeys, t));
          for (float v : x.translation)
            if (!std::isfinite(v)) fail("animation '", clip.name, "' joint '", sk.names[j], "' is not finite");
          for (float v : x.rotation)
            if (!std::isfinite(v)) fail("animation '", clip.name, "' joint '", sk.names[j], "' is not finite");
        }
        clip.frames.push_back(std::move(p));
      }
      ch.clips.push_back(std::move(clip));
    }
  }
  return ch;
}

Character load_character(const std::string& path, const ImportOptions& opt) {
  std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".glb" || ext == ".gltf") return load_gltf(path, opt);
  return load_assimp_character(path, opt);
}

}  // namespace gatcore::character
