#include "gatcore/character/eval/weight_eval.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>

#include <nlohmann/json.hpp>

#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/atomic_file.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

SkinWeights weights_from_super(std::span<const float> dense, std::int64_t num_bones,
                               const std::vector<std::int32_t>& joint_to_bone) {
  GATCORE_CHECK(num_bones > 0 && dense.size() % static_cast<std::size_t>(num_bones) == 0, "weights_from_super: ",
                dense.size(), " weights for ", num_bones, " bones");
  std::vector<std::int32_t> bone_to_joint(static_cast<std::size_t>(num_bones), -1);
  for (std::size_t j = 0; j < joint_to_bone.size(); ++j) {
    const std::int32_t b = joint_to_bone[j];
    GATCORE_CHECK(b >= 0 && b < num_bones, "weights_from_super: joint ", j, " maps to bone ", b, " of ", num_bones);
    GATCORE_CHECK(bone_to_joint[b] < 0, "weights_from_super: joints ", bone_to_joint[b], " and ", j,
                  " both map to bone ", b);
    bone_to_joint[b] = static_cast<std::int32_t>(j);
  }
  const std::int64_t n = static_cast<std::int64_t>(dense.size()) / num_bones;
  SkinWeights w;
  w.ptr.reserve(static_cast<std::size_t>(n) + 1);
  std::vector<std::pair<std::int32_t, float>> row;
  for (std::int64_t v = 0; v < n; ++v) {
    row.clear();
    double sum = 0;
    for (std::int64_t b = 0; b < num_bones; ++b) {
      const float x = dense[static_cast<std::size_t>(v * num_bones + b)];
      GATCORE_CHECK(std::isfinite(x), "weights_from_super: vertex ", v, " bone ", b, " weight is not finite");
      if (x > 0.0f && bone_to_joint[b] >= 0) {
        row.push_back({bone_to_joint[b], x});
        sum += x;
      }
    }
    std::sort(row.begin(), row.end());
    for (const auto& [j, x] : row) {
      w.joint.push_back(j);
      w.weight.push_back(static_cast<float>(x / sum));
    }
    w.ptr.push_back(static_cast<std::int64_t>(w.joint.size()));
  }
  return w;
}

namespace {

// Largest entry of row v over `mask` (ties: the first column); -1 if the mask
// leaves no column.
std::int64_t row_argmax(std::span<const float> x, std::int64_t cols, std::int64_t v, std::span<const std::uint8_t> mask) {
  std::int64_t best = -1;
  for (std::int64_t b = 0; b < cols; ++b) {
    if (!mask.empty() && !mask[static_cast<std::size_t>(b)]) continue;
    if (best < 0 || x[static_cast<std::size_t>(v * cols + b)] > x[static_cast<std::size_t>(v * cols + best)]) best = b;
  }
  return best;
}

void check_dominant_args(const char* what, std::span<const float> predicted, std::span<const float> truth,
                         std::int64_t cols, std::span<const std::uint8_t> mask) {
  GATCORE_CHECK(cols > 0 && predicted.size() == truth.size() && predicted.size() % static_cast<std::size_t>(cols) == 0,
                what, ": ", predicted.size(), " predicted and ", truth.size(), " true values for ", cols, " columns");
  GATCORE_CHECK(mask.empty() || static_cast<std::int64_t>(mask.size()) == cols, what, ": mask has ", mask.size(),
                " entries for ", cols, " columns");
}

}  // namespace

double dominant_accuracy(std::span<const float> predicted, std::span<const float> truth, std::int64_t cols,
                         std::span<const std::uint8_t> mask) {
  check_dominant_args("dominant_accuracy", predicted, truth, cols, mask);
  const std::int64_t n = static_cast<std::int64_t>(predicted.size()) / cols;
  if (n == 0) return 0.0;
  std::int64_t right = 0;
  for (std::int64_t v = 0; v < n; ++v)
    right += row_argmax(predicted, cols, v, mask) == row_argmax(truth, cols, v, mask);
  return static_cast<double>(right) / static_cast<double>(n);
}

std::vector<std::array<std::int64_t, 3>> dominant_confusions(std::span<const float> predicted,
                                                             std::span<const float> truth, std::int64_t cols,
                                                             std::span<const std::uint8_t> mask) {
  check_dominant_args("dominant_confusions", predicted, truth, cols, mask);
  const std::int64_t n = static_cast<std::int64_t>(predicted.size()) / cols;
  std::map<std::pair<std::int64_t, std::int64_t>, std::int64_t> count;
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int64_t t = row_argmax(truth, cols, v, mask), p = row_argmax(predicted, cols, v, mask);
    if (t != p) ++count[{t, p}];
  }
  std::vector<std::array<std::int64_t, 3>> out;
  for (const auto& [k, c] : count) out.push_back({k.first, k.second, c});
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a[2] > b[2]; });
  return out;
}

// Dominant bones as dominant_accuracy's (row_argmax), per boundary
// (eval/boundaries.hpp).
std::vector<BoundaryConfusion> boundary_confusions(std::span<const float> predicted, std::span<const float> truth,
                                                   std::int64_t cols, std::span<const BodyRegion> column_region,
                                                   std::span<const std::uint8_t> mask) {
  check_dominant_args("boundary_confusions", predicted, truth, cols, mask);
  GATCORE_CHECK(static_cast<std::int64_t>(column_region.size()) == cols, "boundary_confusions: ",
                column_region.size(), " column regions for ", cols, " columns");
  using R = BodyRegion;
  constexpr std::array<std::pair<R, R>, 6> sides{{{R::head, R::neck},
                                                  {R::chest, R::neck},
                                                  {R::hips, R::spine},
                                                  {R::upper_arm, R::chest},
                                                  {R::upper_leg, R::lower_leg},
                                                  {R::lower_leg, R::foot}}};
  std::array<BoundaryConfusion, 6> acc{};
  const std::int64_t n = static_cast<std::int64_t>(truth.size()) / cols;
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int64_t t = row_argmax(truth, cols, v, mask), p = row_argmax(predicted, cols, v, mask);
    if (t < 0) continue;
    const R rt = column_region[static_cast<std::size_t>(t)], rp = column_region[static_cast<std::size_t>(p)];
    for (std::size_t b = 0; b < sides.size(); ++b) {
      const auto [x, y] = sides[b];
      if (rt != x && rt != y) continue;
      ++acc[b].vertices;
      acc[b].crossed += rp == (rt == x ? y : x);
    }
  }
  std::vector<BoundaryConfusion> out;
  for (std::size_t b = 0; b < sides.size(); ++b)
    if (acc[b].vertices > 0) {
      acc[b].boundary = kBoundaries[b];
      out.push_back(acc[b]);
    }
  return out;
}

CharacterWeightEval evaluate_character_weights(const PreparedCharacter& pc, std::span<const float> predicted_in,
                                               std::span<const float> truth, std::int64_t num_bones,
                                               const std::vector<std::int32_t>& joint_to_bone,
                                               std::span<const std::uint8_t> mask, const WeightEvalOptions& opts,
                                               std::int32_t character_index) {
  const Mesh& mesh = pc.character.mesh;
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(static_cast<std::int64_t>(predicted_in.size()) == n * num_bones &&
                    static_cast<std::int64_t>(truth.size()) == n * num_bones,
                "evaluate_character_weights: ", predicted_in.size(), " predicted and ", truth.size(),
                " true weights for ", n, " vertices x ", num_bones, " bones");
  GATCORE_CHECK(static_cast<std::int32_t>(joint_to_bone.size()) == pc.character.skeleton.num_joints(),
                "evaluate_character_weights: joint_to_bone has ", joint_to_bone.size(), " entries for ",
                pc.character.skeleton.num_joints(), " joints");
  GATCORE_CHECK(opts.poses >= 0 && opts.worst >= 1, "evaluate_character_weights: poses ", opts.poses, ", worst ",
                opts.worst);
  GATCORE_CHECK(pc.normalisation.scale > 0.0f && std::isfinite(pc.normalisation.scale), "evaluate_character_weights: character scale ",
                pc.normalisation.scale);
  std::vector<float> pruned;
  std::span<const float> predicted = predicted_in;
  if (opts.min_weight > 0.0f) {
    pruned.assign(predicted_in.begin(), predicted_in.end());
    limit_weights_dense(pruned, num_bones, static_cast<int>(num_bones), opts.min_weight, mask);
    predicted = pruned;
  }
  CharacterWeightEval r;
  r.vertices = n;
  r.height = 1.0 / static_cast<double>(pc.normalisation.scale);
  r.weights = weight_metrics(predicted, truth, num_bones, opts.threshold, mask);
  {
    // Bone columns -> the character's joint names.
    std::vector<std::string> bone_name(static_cast<std::size_t>(num_bones));
    for (std::size_t j = 0; j < joint_to_bone.size(); ++j)
      if (joint_to_bone[j] >= 0 && joint_to_bone[j] < num_bones)
        bone_name[static_cast<std::size_t>(joint_to_bone[j])] = pc.character.skeleton.names[j];
    const auto name = [&](std::int64_t b) {
      if (b < 0) return std::string("(none)");
      const std::string& s = bone_name[static_cast<std::size_t>(b)];
      return s.empty() ? "bone " + std::to_string(b) : s;
    };
    // One pass for both: the dominant bone is right wherever it is not confused.
    std::int64_t wrong = 0;
    for (const auto& [t, p, c] : dominant_confusions(predicted, truth, num_bones, mask)) {
      r.confusions.push_back({name(t), name(p), c});
      wrong += c;
    }
    r.dominant = n > 0 ? static_cast<double>(n - wrong) / static_cast<double>(n) : 0.0;
    const std::vector<BodyRegion> joint_region = body_regions(pc.character.skeleton);
    std::vector<BodyRegion> column_region(static_cast<std::size_t>(num_bones), BodyRegion::other);
    for (std::size_t j = 0; j < joint_to_bone.size(); ++j)
      if (joint_to_bone[j] >= 0 && joint_to_bone[j] < num_bones)
        column_region[static_cast<std::size_t>(joint_to_bone[j])] = joint_region[j];
    r.boundaries = boundary_confusions(predicted, truth, num_bones, column_region, mask);
  }
  r.vertex_l1.resize(static_cast<std::size_t>(n));
  for (std::int64_t v = 0; v < n; ++v) {
    double l1 = 0;
    for (std::int64_t b = 0; b < num_bones; ++b) {
      if (!mask.empty() && !mask[static_cast<std::size_t>(b)]) continue;
      const std::size_t i = static_cast<std::size_t>(v * num_bones + b);
      l1 += std::abs(static_cast<double>(predicted[i]) - truth[i]);
    }
    r.vertex_l1[static_cast<std::size_t>(v)] = static_cast<float>(l1);
  }
  if (opts.poses > 0) {
    const Skeleton& sk = pc.character.skeleton;
    const auto limits = uniform_limits(sk, opts.pose_angle);
    std::mt19937 rng(opts.seed ^ (0x9e3779b9u * static_cast<std::uint32_t>(character_index + 1)));
    std::vector<Pose> poses;
    for (int p = 0; p < opts.poses; ++p) poses.push_back(random_pose(sk, pc.rest, limits, rng));
    r.deformation = deformation_error(pc, weights_from_super(predicted, num_bones, joint_to_bone),
                                      weights_from_super(truth, num_bones, joint_to_bone), poses, opts.worst);
  }
  return r;
}

DistanceStats deformation_error(const PreparedCharacter& pc, const SkinWeights& predicted, const SkinWeights& truth,
                                std::span<const Pose> poses, int worst) {
  const std::int64_t n = pc.character.mesh.num_vertices();
  GATCORE_CHECK(predicted.num_vertices() == n && truth.num_vertices() == n, "deformation_error: ",
                predicted.num_vertices(), " predicted and ", truth.num_vertices(), " true weight rows for ", n,
                " vertices");
  GATCORE_CHECK(pc.normalisation.scale > 0.0f && std::isfinite(pc.normalisation.scale), "deformation_error: character scale ",
                pc.normalisation.scale);
  Mesh pred = pc.character.mesh, gt = pc.character.mesh;
  pred.weights = predicted;
  gt.weights = truth;
  const Skeleton& sk = pc.character.skeleton;
  std::vector<std::vector<float>> distances(poses.size());
  for (std::size_t p = 0; p < poses.size(); ++p) {
    const std::vector<Mat4> m = skinning_matrices(sk, poses[p]);
    const std::vector<float> a = linear_blend_skinning(pred, m), b = linear_blend_skinning(gt, m);
    auto& d = distances[p];
    d.resize(static_cast<std::size_t>(n));
    for (std::int64_t v = 0; v < n; ++v) {
      const std::size_t i = static_cast<std::size_t>(3 * v);
      const double dx = a[i] - b[i], dy = a[i + 1] - b[i + 1], dz = a[i + 2] - b[i + 2];
      d[static_cast<std::size_t>(v)] = static_cast<float>(std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  }
  return worst_poses_error(distances, 1.0 / static_cast<double>(pc.normalisation.scale), worst);
}

WeightEvalSummary summarise_weight_eval(const std::vector<CharacterWeightEval>& per_character) {
  WeightEvalSummary s;
  s.characters = static_cast<int>(per_character.size());
  for (const auto& c : per_character) {
    s.precision += c.weights.precision;
    s.recall += c.weights.recall;
    s.l1_mean += c.weights.l1_mean;
    s.deform_mean += c.deformation.mean;
    s.dominant += c.dominant;
    s.l1_max = std::max(s.l1_max, c.weights.l1_max);
    s.deform_max = std::max(s.deform_max, c.deformation.max);
  }
  if (s.characters > 0) {
    const double k = static_cast<double>(s.characters);
    s.precision /= k, s.recall /= k, s.l1_mean /= k, s.deform_mean /= k, s.dominant /= k;
  }
  return s;
}

namespace {

std::string fmt(const char* f, double x) {
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

std::string row(const std::string& name, const std::string& vertices, double p, double r, double l1m, double l1x,
                double dm, double dx, double dom) {
  return "| " + name + " | " + vertices + " | " + fmt("%.3f", p) + " | " + fmt("%.3f", r) + " | " +
         fmt("%.4f", l1m) + " | " + fmt("%.4f", l1x) + " | " + fmt("%.5f", dm) + " | " + fmt("%.4f", dx) + " | " +
         fmt("%.3f", dom) + " |\n";
}

}  // namespace

std::string weight_eval_markdown(const std::vector<CharacterWeightEval>& per_character) {
  std::string s =
      "| character | vertices | precision | recall | L1 mean | L1 max | deform. mean / height | deform. max / height | "
      "dominant bone |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& c : per_character)
    s += row(c.name, std::to_string(c.vertices), c.weights.precision, c.weights.recall, c.weights.l1_mean,
             c.weights.l1_max, c.deformation.mean, c.deformation.max, c.dominant);
  const WeightEvalSummary o = summarise_weight_eval(per_character);
  s += row("**overall**", "", o.precision, o.recall, o.l1_mean, o.l1_max, o.deform_mean, o.deform_max, o.dominant);
  return s;
}

namespace {

// Per boundary, the characters' vertices and crossings summed.
std::vector<BoundaryConfusion> sum_boundaries(const std::vector<CharacterWeightEval>& per_character) {
  std::vector<BoundaryConfusion> total;
  for (const Boundary b : kBoundaries) {
    BoundaryConfusion t;
    t.boundary = b;
    for (const auto& c : per_character)
      for (const auto& x : c.boundaries)
        if (x.boundary == b) t.vertices += x.vertices, t.crossed += x.crossed;
    if (t.vertices > 0) total.push_back(t);
  }
  return total;
}

nlohmann::json boundaries_json(const std::vector<BoundaryConfusion>& bs) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& b : bs)
    list.push_back({{"boundary", boundary_name(b.boundary)}, {"vertices", b.vertices}, {"crossed", b.crossed}});
  return list;
}

}  // namespace

std::string weight_eval_confusions_markdown(const std::vector<CharacterWeightEval>& per_character, int top) {
  if (top < 1) return {};
  std::string s = "\nDominant bone: where it differs from the artist's (artist's joint -> predicted joint: vertices)\n";
  for (const auto& c : per_character) {
    s += "- " + c.name + ":";
    if (c.confusions.empty()) s += " none";
    for (std::size_t i = 0; i < c.confusions.size() && i < static_cast<std::size_t>(top); ++i)
      s += std::string(i ? "," : "") + " " + c.confusions[i].truth + " -> " + c.confusions[i].predicted + ": " +
           std::to_string(c.confusions[i].vertices);
    s += "\n";
    if (!c.boundaries.empty()) {
      s += "  boundaries (crossed / vertices):";
      for (const auto& b : c.boundaries)
        s += std::string(" ") + boundary_name(b.boundary) + " " + std::to_string(b.crossed) + "/" +
             std::to_string(b.vertices) + ";";
      s += "\n";
    }
  }
  const auto total = sum_boundaries(per_character);
  if (!total.empty()) {
    s += "\n| boundary | vertices | crossed | crossed share |\n|---|---:|---:|---:|\n";
    for (const auto& b : total) {
      char share[32];
      std::snprintf(share, sizeof share, "%.3f", static_cast<double>(b.crossed) / static_cast<double>(b.vertices));
      s += std::string("| ") + boundary_name(b.boundary) + " | " + std::to_string(b.vertices) + " | " +
           std::to_string(b.crossed) + " | " + share + " |\n";
    }
  }
  return s;
}

std::string weight_eval_json(const std::string& method, const std::vector<CharacterWeightEval>& per_character,
                             const WeightEvalOptions& opts, int confusions) {
  nlohmann::json j;
  j["method"] = method;
  j["options"] = {{"poses", opts.poses},   {"pose_angle", opts.pose_angle}, {"seed", opts.seed},
                  {"threshold", opts.threshold}, {"worst", opts.worst},
                  {"min_weight", opts.min_weight}};
  j["characters"] = nlohmann::json::array();
  for (const auto& c : per_character)
    j["characters"].push_back({{"name", c.name},
                               {"vertices", c.vertices},
                               {"height", c.height},
                               {"precision", c.weights.precision},
                               {"recall", c.weights.recall},
                               {"l1_mean", c.weights.l1_mean},
                               {"l1_max", c.weights.l1_max},
                               {"deform_mean", c.deformation.mean},
                               {"deform_max", c.deformation.max},
                               {"dominant", c.dominant}});
  if (confusions > 0)
    for (std::size_t i = 0; i < per_character.size(); ++i) {
      nlohmann::json list = nlohmann::json::array();
      const auto& cs = per_character[i].confusions;
      for (std::size_t k = 0; k < cs.size() && k < static_cast<std::size_t>(confusions); ++k)
        list.push_back({{"truth", cs[k].truth}, {"predicted", cs[k].predicted}, {"vertices", cs[k].vertices}});
      j["characters"][i]["confusions"] = std::move(list);
      j["characters"][i]["boundaries"] = boundaries_json(per_character[i].boundaries);
    }
  const WeightEvalSummary o = summarise_weight_eval(per_character);
  j["overall"] = {{"characters", o.characters}, {"precision", o.precision},     {"recall", o.recall},
                  {"l1_mean", o.l1_mean},       {"l1_max", o.l1_max},           {"deform_mean", o.deform_mean},
                  {"deform_max", o.deform_max}, {"dominant", o.dominant}};
  if (confusions > 0) j["overall"]["boundaries"] = boundaries_json(sum_boundaries(per_character));
  return j.dump(2) + "\n";
}

void write_text_atomic(const std::string& path, const std::string& text) { write_file_atomic(path, text); }

}  // namespace gatcore::character
