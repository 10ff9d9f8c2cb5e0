// The skeleton-agnostic skin-weight model: bone-candidate features
// (features/bone_candidates.hpp), its samples (data/bone_candidate_samples.hpp),
// training on characters with different bone counts in one batch, and
// prediction that depends on no joint name (inference/weight_prediction.hpp).
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "character_fixtures.hpp"
#include "pose_fixtures.hpp"
#include "model_gradcheck.hpp"
#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/metrics.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/train.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

PreparedCharacter procedural(ProceduralKind kind, std::uint32_t seed) {
  ProceduralOptions o;
  o.kind = kind;
  o.seed = seed;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  return prepare_character(procedural_character(o), DeltaMushParams{0, 0.5f});
}

// The bone heat new skinweights-any models read (their defaults' rules).
BoneHeatParams new_model_heat() {
  return prior_bone_heat(models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(4), 4));
}

// A skinweights-any small enough for tests to run in milliseconds.
models::ModelConfig small_any_config(int k) {
  models::ModelConfig cfg = models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(k), k);
  cfg.stage1 = {16, 8};
  cfg.gc_dims = {8, 8, 8};
  cfg.global_mlp = {16};
  cfg.classifier = {16};
  // What the network computes, without the default's dropout: a random mask
  // per forward pass would change the function between a finite difference's
  // two evaluations. The dropout test below turns it on.
  cfg.classifier_dropout = 0.0f;
  return cfg;
}

// The prior's model starts with a zero last layer (it is bone heat, whatever
// the rest); tests of what the network does draw that layer at random.
void randomise_last_layer(models::Model& m, std::uint32_t seed) {
  const std::string last = m.config().pair_scorer.empty()
                               ? "classifier." + std::to_string(m.config().classifier.size()) + "."
                               : std::string("scorer.out.");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-0.5f, 0.5f);
  int found = 0;
  for (const auto& p : m.registry().params) {
    if (p.name.rfind(last, 0) != 0) continue;
    ++found;
    const Tensor& x = p.var.value();
    for (std::int64_t i = 0; i < x.rows(); ++i)
      for (std::int64_t j = 0; j < x.cols(); ++j) x.at(i, j) = U(rng);
  }
  REQUIRE(found == 2);  // W and b
}

// The training loss (the model's: cfg.weight_loss) on `train` before and
// after `epochs` whole-mesh epochs of `batch` characters at a rate of 3e-3.
std::pair<double, double> loss_before_after(models::Model& m, const models::Normaliser& norm,
                                          const std::vector<models::Sample>& train, int batch, int epochs) {
  models::TrainOptions opt = models::TrainOptions::defaults_for(m.config());
  opt.batch_size = batch;
  // Whole meshes: a random subset's induced graph has few edges and its max
  // pool is not the whole mesh's, so evaluation (whole meshes) would lag.
  opt.sampling = models::Sampling::full;
  opt.lr = 3e-3f;
  models::Trainer t(m, opt, norm);
  const double before = t.evaluate(train);
  for (int e = 0; e < epochs; ++e) t.run_epoch(train);
  return {before, t.evaluate(train)};
}

}  // namespace

TEST_CASE("bone candidates of a two-bone tube: nearest first, padded past the joint count", "[skin_any]") {
  const PreparedCharacter pc = prepare_character(charfix::tube_character(12, 8, 2.0f, 0.25f, 0.0f));
  const BoneCandidates c = bone_candidate_features(pc, 4, new_model_heat());
  const std::int64_t n = pc.character.mesh.num_vertices();
  REQUIRE(c.k == 4);
  REQUIRE(c.valid == 2);
  REQUIRE(c.features.rows() == n);
  REQUIRE(c.features.cols() == bone_candidate_feature_dim(4));
  const float s = pc.normalisation.scale;  // normalised lengths: world * scale
  for (std::int64_t v = 0; v < n; ++v) {
    const float y = pc.character.mesh.positions[3 * v + 1];
    const float r = std::hypot(pc.character.mesh.positions[3 * v], pc.character.mesh.positions[3 * v + 2]);
    CHECK(c.joint[v * 4 + 2] == -1);
    CHECK(c.joint[v * 4 + 3] == -1);
    for (int k = 6 + 2 * kPairFeatures; k < c.features.cols(); ++k) CHECK(c.features.at(v, k) == 0.0f);
    // Skip the joint (ties), cap centres and the part past the leaf bone (y > 1.5).
    if (std::abs(y - 1.0f) < 0.1f || r < 0.2f || y > 1.5f) continue;
    CHECK(c.joint[v * 4] == (y < 1.0f ? 0 : 1));
    const float* f = c.features.data() + v * c.features.cols() + 6;
    CHECK(f[0] == Approx(0.25f * s).margin(1e-4));                 // distance = radius
    CHECK(f[1] == 0.0f);                                           // nearest minus nearest
    CHECK(f[kPairFeatures + 1] == Approx(f[kPairFeatures] - f[0]).margin(1e-6));  // second minus nearest
    CHECK(f[kPairFeatures] > f[0]);
    // Bone length: root 1 (world); bone1, a leaf, half its parent's.
    CHECK(f[5] == Approx((y < 1.0f ? 1.0f : 0.5f) * s).margin(1e-4));
    CHECK(f[kBoneHeatPairColumn] > 0.6f);                          // bone heat: mostly the nearest bone
    CHECK(f[9] + f[kPairFeatures + 9] == Approx(1.0f).margin(1e-4));  // two bones: heat sums to 1
  }
  // Targets: the artist's weights of the candidates (blend 0: one-hot).
  const Tensor t = candidate_targets(c, pc.character.mesh.weights);
  for (std::int64_t v = 0; v < n; ++v) {
    double sum = 0;
    for (int k = 0; k < 4; ++k) sum += t.at(v, k);
    CHECK(sum == Approx(1.0));
  }
  CHECK_THROWS_AS(bone_candidate_features(pc, 0, new_model_heat()), InvalidArgument);
}

TEST_CASE("skinweights-any trains on characters with different bone counts in one batch", "[skin_any]") {
  // A humanoid (19 joints: every vertex has 4 candidates) and a two-bone tube
  // (2 candidates, 2 masked): one batch, one softmax width.
  const PreparedCharacter a = procedural(ProceduralKind::humanoid, 1);
  const PreparedCharacter b = prepare_character(charfix::tube_character(12, 8, 2.0f, 0.25f, 0.3f));
  REQUIRE(a.character.skeleton.num_joints() != b.character.skeleton.num_joints());
  const int k = 4;
  std::vector<models::Sample> train{bone_candidate_sample(a, k, new_model_heat()), bone_candidate_sample(b, k, new_model_heat())};
  CHECK(train[1].bone_mask.at(0, 1) == 1.0f);
  CHECK(train[1].bone_mask.at(0, 2) == 0.0f);
  // Both scorers: the classifier's column per slot, and one MLP shared by
  // every (vertex, candidate) pair; both losses.
  const bool shared = GENERATE(false, true);
  const models::WeightLoss loss = GENERATE(models::WeightLoss::kl, models::WeightLoss::l1);
  models::ModelConfig cfg = models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(k), k);
  cfg.weight_loss = loss;
  cfg.stage1 = {32, 16};
  cfg.gc_dims = {16, 16, 16};
  cfg.global_mlp = {32};
  cfg.classifier = {32};
  if (shared) {
    cfg.pair_scorer = {16};
    cfg.pair_features = kPairFeatures;
  }
  INFO("pair scorer " << shared << ", loss " << models::weight_loss_name(loss));
  auto model = models::make_model(cfg, 3);
  REQUIRE(model->pool_sizes().empty());
  const models::Normaliser norm = models::Normaliser::fit(train, false);
  // Both characters in one batch: per-character candidate masks, one softmax width.
  const auto [before, after] = loss_before_after(*model, norm, train, 2, 60);
  INFO("loss before " << before << ", after " << after);
  CHECK(std::isfinite(after));
  // L1 falls more slowly than KL (a sign gradient, no log barrier): both
  // thresholds are well below what 60 epochs of an unlearning model give.
  CHECK(after < (loss == models::WeightLoss::kl ? 0.6 : 0.75) * before);
  // Masked candidates get exactly zero.
  const Tensor y = models::predict(*model, train[1], norm, 0);
  for (std::int64_t v = 0; v < y.rows(); ++v) {
    CHECK(y.at(v, 2) == 0.0f);
    CHECK(y.at(v, 3) == 0.0f);
  }
}

TEST_CASE("finite-difference gradients through a reduced skinweights-any, two bone counts in one batch", "[skin_any]") {
  // The shared scorer (per vertex: stage-1 MLP, graph attention over the
  // mesh, the per-candidate head) and the softmax over each vertex's own
  // valid candidates: a humanoid (4 valid of 4) and a two-bone tube (2 of 4,
  // 2 masked) in one batch, gradients of every parameter against central
  // differences.
  ProceduralOptions po;
  po.kind = ProceduralKind::humanoid;
  po.seed = 2;
  po.ring_segments = 4;  // small meshes: few vertices near a kink of the
  po.rings_per_bone = 1; // leaky ReLUs or the max pool within the step
  const PreparedCharacter a = prepare_character(procedural_character(po), DeltaMushParams{0, 0.5f});
  // The tube's vertices jittered: a symmetric tube has vertices with equal
  // features, and the per-character max pool is not differentiable at such
  // ties (central differences then see the mean of the one-sided slopes).
  Character tube = charfix::tube_character(4, 5, 2.0f, 0.25f, 0.3f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jitter(-0.03f, 0.03f);
  for (float& x : tube.mesh.positions) x += jitter(rng);
  const PreparedCharacter b = prepare_character(tube);
  const int k = 4;
  std::vector<models::Sample> data{bone_candidate_sample(a, k, new_model_heat()), bone_candidate_sample(b, k, new_model_heat())};
  models::ModelConfig cfg = models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(k), k);
  cfg.stage1 = {8};
  cfg.gc_heads = {2, 1};
  cfg.gc_dims = {4, 4};
  cfg.gc_pool = {0, 0};  // no geodesic pooling (skinweights-any)
  cfg.global_mlp = {8};
  cfg.classifier = {8};
  cfg.classifier_dropout = 0.0f;  // one function for both evaluations of a finite difference
  const bool shared = GENERATE(false, true);  // the shared pair scorer: 2 hidden layers, every slot
  if (shared) {
    cfg.pair_scorer = {6, 5};
    cfg.pair_features = kPairFeatures;
  }
  INFO("pair scorer " << shared);
  REQUIRE(cfg.logit_prior);  // logits = network + log(bone heat + eps)
  auto model = models::make_model(cfg, 11);
  randomise_last_layer(*model, 13);  // zero, every layer below it would get a zero gradient
  const models::Normaliser norm = models::Normaliser::fit(data, false);
  std::vector<const models::Sample*> p{&data[0], &data[1]};
  const models::Batch batch = models::make_batch(p, {{}, {}}, norm, model->pool_sizes());
  REQUIRE(batch.mask.defined());
  REQUIRE(batch.prior.defined());
  const auto e = fixtures::model_gradcheck(*model, batch);
  CHECK(e.size() >= 3 * model->registry().params.size());
}

TEST_CASE("skinweights-any predicts the same weights whatever the joints are called", "[skin_any]") {
  ProceduralOptions o;
  o.seed = 4;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  const Character original = procedural_character(o);
  Character renamed = original;
  for (std::size_t j = 0; j < renamed.skeleton.names.size(); ++j)
    renamed.skeleton.names[j] = "mixamorig:Bone_" + std::to_string(97 * j % 101);
  const int k = 4;
  models::ModelConfig cfg = small_any_config(k);
  const bool shared = GENERATE(false, true);
  if (shared) {
    cfg.pair_scorer = {8};
    cfg.pair_features = kPairFeatures;
  }
  auto model = models::make_model(cfg, 5);
  randomise_last_layer(*model, 6);  // not just bone heat: the network's own scores too
  const PreparedCharacter pc = prepare_character(original, DeltaMushParams{0, 0.5f});
  const models::Normaliser norm = models::Normaliser::fit({bone_candidate_sample(pc, k, new_model_heat())}, false);
  const WeightPrediction p = predict_skin_weights_any(*model, norm, original, 3);
  const WeightPrediction q = predict_skin_weights_any(*model, norm, renamed, 3);
  REQUIRE(p.weights.num_vertices() == original.mesh.num_vertices());
  CHECK(p.weights.ptr == q.weights.ptr);
  CHECK(p.weights.joint == q.weights.joint);
  CHECK(p.weights.weight == q.weights.weight);
  CHECK(p.weights.max_influences() <= 3);
  for (std::int64_t v = 0; v < p.weights.num_vertices(); ++v) {
    double s = 0;
    for (std::int64_t e = p.weights.ptr[v]; e < p.weights.ptr[v + 1]; ++e) {
      CHECK(p.weights.joint[e] >= 0);
      CHECK(p.weights.joint[e] < original.skeleton.num_joints());
      s += p.weights.weight[e];
    }
    CHECK(s == Approx(1.0).epsilon(1e-5));
  }
  // Another model is refused, naming it.
  auto other = models::make_model(models::ModelConfig::defaults("fc", bone_candidate_feature_dim(k), k), 1);
  CHECK_THROWS_AS(predict_skin_weights_any(*other, norm, original, 3), InvalidArgument);
}

namespace {
// Vertices whose weights differ by more than tol (L1 over their joints).
int count_different(const SkinWeights& a, const SkinWeights& b, double tol) {
  REQUIRE(a.num_vertices() == b.num_vertices());
  int differ = 0;
  for (std::int64_t v = 0; v < a.num_vertices(); ++v) {
    std::map<std::int32_t, double> w;
    for (std::int64_t e = a.ptr[v]; e < a.ptr[v + 1]; ++e) w[a.joint[e]] += a.weight[e];
    for (std::int64_t e = b.ptr[v]; e < b.ptr[v + 1]; ++e) w[b.joint[e]] -= b.weight[e];
    double d = 0;
    for (const auto& [j, x] : w) d += std::abs(x);
    differ += d > tol;
  }
  return differ;
}
void check_same_weights(const SkinWeights& a, const SkinWeights& b, double tol) {
  CHECK(count_different(a, b, tol) == 0);
}
// The procedural humanoid jittered by up to 2 mm: its rings sit exactly on
// the joints, where two bones tie for nearest and float noise picks the
// winner (in any frame, scaled, moved or turned); a scanned or sculpted mesh
// has no such ties. Copies of a point along seams move together (the mesh
// stays closed).
Character jittered_humanoid(std::uint32_t seed, std::uint32_t jitter_seed) {
  Character c = posefix::humanoid(seed);
  std::mt19937 rng(jitter_seed);
  std::uniform_real_distribution<float> J(-2e-3f, 2e-3f);
  std::map<std::array<float, 3>, std::array<float, 3>> moved;
  for (std::size_t i = 0; i + 2 < c.mesh.positions.size(); i += 3) {
    float* x = &c.mesh.positions[i];
    const auto [it, fresh] = moved.try_emplace({x[0], x[1], x[2]}, std::array<float, 3>{});
    if (fresh) it->second = {x[0] + J(rng), x[1] + J(rng), x[2] + J(rng)};
    for (int d = 0; d < 3; ++d) x[d] = it->second[std::size_t(d)];
  }
  return c;
}
}  // namespace

TEST_CASE("skinweights-any and bone heat give the same weights in centimetres and moved", "[skin_any]") {
  const Character metres = jittered_humanoid(7, 11);
  // 13 m away: a float keeps 1e-4 cm there, far below the mesh's detail
  // (a character kilometres from the origin loses its shape in the file).
  const Character cm = posefix::moved_and_scaled(metres, 100.f, {250.f, -40.f, 1300.f});
  // The fixture really moved the bind space and the joints with it.
  const Skeleton& sk = cm.skeleton;
  REQUIRE(std::abs(cm.mesh.positions[1] - (100.f * metres.mesh.positions[1] - 40.f)) < 1e-2f);
  REQUIRE(std::abs(inverse(sk.inverse_bind[0])[13] - (100.f * inverse(metres.skeleton.inverse_bind[0])[13] - 40.f)) <
          1e-2f);
  const int k = 4;
  models::ModelConfig cfg = small_any_config(k);
  auto model = models::make_model(cfg, 5);
  randomise_last_layer(*model, 8);
  const PreparedCharacter pc = prepare_character(metres, DeltaMushParams{0, 0.5f});
  const models::Normaliser norm = models::Normaliser::fit({bone_candidate_sample(pc, k, new_model_heat())}, false);
  SECTION("skinweights-any") {
    const WeightPrediction p = predict_skin_weights_any(*model, norm, metres, 3);
    const WeightPrediction q = predict_skin_weights_any(*model, norm, cm, 3);
    check_same_weights(p.weights, q.weights, 1e-3);
  }
  SECTION("bone heat") {
    check_same_weights(bone_heat_weights(metres), bone_heat_weights(cm), 1e-3);
  }
}

TEST_CASE("skinweights-any that ignores the world columns gives a turned character the same weights", "[skin_any]") {
  // Turned a quarter about the vertical axis (exactly: the matrix holds 0 and
  // +-1), every bone-relative column is unchanged -- distances, positions
  // along and off the bone, height above it, lengths, depth, bone heat --
  // while the vertex's world position and normal are not. Jittered, so no
  // two bones tie for nearest.
  const Character c = jittered_humanoid(3, 5);
  Mat4 turn = mat4_identity();
  turn[0] = turn[10] = 0.0f;
  turn[2] = -1.0f;  // x -> -z
  turn[8] = 1.0f;   // z -> x
  Character turned = c;
  for (std::size_t i = 0; i + 2 < c.mesh.positions.size(); i += 3) {
    const Vec3 p = transform_point(turn, {c.mesh.positions[i], c.mesh.positions[i + 1], c.mesh.positions[i + 2]});
    for (int d = 0; d < 3; ++d) turned.mesh.positions[i + std::size_t(d)] = p[std::size_t(d)];
  }
  for (std::int32_t j = 0; j < c.skeleton.num_joints(); ++j) {
    turned.skeleton.inverse_bind[std::size_t(j)] = mul(c.skeleton.inverse_bind[std::size_t(j)], inverse(turn));
    if (c.skeleton.parents[std::size_t(j)] < 0)
      turned.skeleton.root_parent[std::size_t(j)] = mul(turn, c.skeleton.root_parent[std::size_t(j)]);
  }
  const int k = 4;
  const PreparedCharacter pc = prepare_character(c, DeltaMushParams{0, 0.5f});
  const PreparedCharacter pt = prepare_character(turned, DeltaMushParams{0, 0.5f});
  const models::Sample sc = bone_candidate_sample(pc, k, new_model_heat()), st = bone_candidate_sample(pt, k, new_model_heat());
  // The fixture turned the character: the world columns moved, the pair columns did not.
  double world = 0, pair = 0;
  for (std::int64_t v = 0; v < sc.features.rows(); ++v)
    for (std::int64_t j = 0; j < sc.features.cols(); ++j) {
      const double d = std::abs(double(sc.features.at(v, j)) - st.features.at(v, j));
      (j < kVertexColumns ? world : pair) = std::max(j < kVertexColumns ? world : pair, d);
    }
  REQUIRE(world > 0.1);
  REQUIRE(pair < 1e-3);

  models::ModelConfig cfg = small_any_config(k);
  auto model = models::make_model(cfg, 5);
  randomise_last_layer(*model, 10);
  models::Normaliser norm = models::Normaliser::fit({sc}, false);
  CHECK_FALSE(ignores_world_columns(norm));
  SECTION("using them, the weights turn with the world columns") {
    const WeightPrediction p = predict_skin_weights_any(*model, norm, c, 3);
    const WeightPrediction q = predict_skin_weights_any(*model, norm, turned, 3);
    CHECK(count_different(p.weights, q.weights, 1e-2) > 10);
  }
  SECTION("ignoring them, the weights are the same") {
    const Tensor before = norm.inv_std.clone();
    ignore_world_columns(norm);
    CHECK(ignores_world_columns(norm));
    for (std::int64_t j = 0; j < norm.inv_std.cols(); ++j)
      CHECK(norm.inv_std.at(0, j) == (j < kVertexColumns ? 0.0f : before.at(0, j)));
    const WeightPrediction p = predict_skin_weights_any(*model, norm, c, 3);
    const WeightPrediction q = predict_skin_weights_any(*model, norm, turned, 3);
    CHECK(count_different(p.weights, q.weights, 1e-3) == 0);
  }
  SECTION("a normaliser without the vertex columns is refused") {
    models::Normaliser narrow;
    narrow.mean = Tensor::zeros(1, 4);
    narrow.inv_std = Tensor::zeros(1, 4);
    CHECK_THROWS_AS(ignore_world_columns(narrow), InvalidArgument);
    CHECK_FALSE(ignores_world_columns(narrow));
    CHECK_FALSE(ignores_world_columns(models::Normaliser{}));
  }
}

TEST_CASE("untrained skinweights-any is bone heat over each vertex's candidates", "[skin_any]") {
  // The log prior and the zero last layer: softmax(log(h + eps)) over the
  // valid candidates, h bone heat's weight of the candidate joint, by the
  // rules the config names (computed here from bone_heat_weights, not read
  // back from the features).
  const bool shared = GENERATE(false, true);
  const bool current = GENERATE(false, true);
  for (const int k : {4, 8}) {
    INFO("k " << k << ", pair scorer " << shared << ", current rules " << current);
    const PreparedCharacter pc = procedural(ProceduralKind::humanoid, 6);
    models::ModelConfig cfg = small_any_config(k);
    cfg.prior_weight_limit = cfg.prior_straight_chains = current;
    if (shared) {
      cfg.pair_scorer = {8};
      cfg.pair_features = kPairFeatures;
    }
    BoneCandidates c;
    const models::Sample s = bone_candidate_sample(pc, k, prior_bone_heat(cfg), &c);
    auto model = models::make_model(cfg, 9);
    const models::Normaliser norm = models::Normaliser::fit({s}, false);
    const Tensor y = models::predict(*model, s, norm, 0);
    // The inference path reads the rules from the model's config.
    const SkinWeights own = predict_skin_weights_any(*model, norm, pc, k);
    BoneHeatParams hp;
    hp.max_influences = 64;
    hp.min_weight = 0.0f;
    if (!current) {
      hp.cut_below = 0.0f;
      hp.continue_cos = 2.0f;
    }
    const SkinWeights heat = bone_heat_weights(pc.character, hp);
    const std::int64_t n = pc.character.mesh.num_vertices();
    REQUIRE(y.rows() == n);
    int compared = 0;
    for (std::int64_t v = 0; v < n; ++v) {
      std::vector<double> h(std::size_t(k), 0.0);
      double sum = 0;
      for (int i = 0; i < c.valid; ++i) {
        for (std::int64_t e = heat.ptr[v]; e < heat.ptr[v + 1]; ++e)
          if (heat.joint[e] == c.joint[std::size_t(v * k + i)]) h[std::size_t(i)] = heat.weight[e];
        sum += h[std::size_t(i)];
      }
      // Where bone heat puts most of the vertex outside its candidates, the
      // eps floor is not small next to what is left: compare where it is.
      if (sum < 0.5) continue;
      ++compared;
      for (int i = 0; i < c.valid; ++i) {
        CHECK(y.at(v, i) == Approx(h[std::size_t(i)] / sum).margin(2.0 * k * kBoneHeatPriorEps / sum + 1e-5));
        float w = 0.0f;
        for (std::int64_t e = own.ptr[v]; e < own.ptr[v + 1]; ++e)
          if (own.joint[e] == c.joint[std::size_t(v * k + i)]) w = own.weight[e];
        CHECK(w == Approx(h[std::size_t(i)] / sum).margin(2.0 * k * kBoneHeatPriorEps / sum + 1e-5));
      }
    }
    // Bone heat's facing distance sends some skin (a chest under an arm) to
    // a bone behind it that is not among its nearest candidates: about 10 %
    // of this character's vertices at k = 4.
    INFO("k " << k << ": " << compared << " of " << n << " vertices compared");
    CHECK(compared > 0.85 * double(n));
    // Training moves it: the gradient reaches the zero last layer.
    models::TrainOptions opt = models::TrainOptions::defaults_for(cfg);
    opt.batch_size = 1;
    opt.sample_vertices = 256;
    models::Trainer t(*model, opt, norm);
    t.run_epoch({s});
    const Tensor z = models::predict(*model, s, norm, 0);
    double moved = 0;
    for (std::int64_t v = 0; v < n; ++v)
      for (int i = 0; i < k; ++i) moved = std::max(moved, double(std::abs(z.at(v, i) - y.at(v, i))));
    CHECK(moved > 1e-4);
  }
}

TEST_CASE("the classifier's dropout acts while training only, and is recorded in the configuration", "[skin_any]") {
  const PreparedCharacter a = procedural(ProceduralKind::humanoid, 1);
  const int k = 4;
  const std::vector<models::Sample> train{bone_candidate_sample(a, k, new_model_heat())};
  const models::Normaliser norm = models::Normaliser::fit(train, false);
  models::ModelConfig plain = small_any_config(k);
  plain.classifier = {32, 16};
  models::ModelConfig dropped = plain;
  dropped.classifier_dropout = 0.5f;
  // The same seed draws the same weights: dropout takes no initial values.
  auto p = models::make_model(plain, 5), d = models::make_model(dropped, 5);
  randomise_last_layer(*p, 9);
  randomise_last_layer(*d, 9);
  const models::Batch b = models::make_batch({&train[0]}, {{}}, norm, {});
  const Tensor pe = p->forward(b, false).value(), de = d->forward(b, false).value();
  const Tensor pt = p->forward(b, true).value(), dt = d->forward(b, true).value();
  REQUIRE(pe.rows() == de.rows());
  double eval_diff = 0, train_diff = 0;
  for (std::int64_t v = 0; v < pe.rows(); ++v)
    for (std::int64_t j = 0; j < pe.cols(); ++j) {
      eval_diff = std::max(eval_diff, double(std::fabs(pe.at(v, j) - de.at(v, j))));
      train_diff = std::max(train_diff, double(std::fabs(pt.at(v, j) - dt.at(v, j))));
    }
  CHECK(eval_diff == 0.0);  // inference (and validation) never drops units
  CHECK(train_diff > 1e-3);
  // A configuration round-trips the rate; one written before the key reads as none.
  CHECK(models::ModelConfig::from_text(dropped.to_text()) == dropped);
  CHECK(models::ModelConfig::from_text("name = skinweights-any\n").classifier_dropout == 0.0f);
  // A rate that would drop every unit (or a negative one, from an edited file) is refused by name.
  for (const float bad : {1.0f, -0.1f}) {
    dropped.classifier_dropout = bad;
    CHECK_THROWS_WITH(models::make_model(dropped, 5), Catch::Contains("classifier_dropout must be in [0, 1)"));
  }
  // It still learns: the dropped model's loss on its character falls as the plain one's does.
  const auto [before, after] = loss_before_after(*d, norm, train, 1, 40);
  INFO("loss before " << before << ", after " << after);
  CHECK(after < 0.7 * before);
}

TEST_CASE("a batch takes every sample's log prior or none", "[skin_any]") {
  const PreparedCharacter a = procedural(ProceduralKind::humanoid, 1);
  const models::Sample with = bone_candidate_sample(a, 4, new_model_heat());
  models::Sample without = with;
  without.prior = Tensor{};
  CHECK_THROWS_AS(models::make_batch({&with, &without}, {{}, {}}, {}, {}), InvalidArgument);
  CHECK_THROWS_AS(models::make_batch({&without, &with}, {{}, {}}, {}, {}), InvalidArgument);
  const std::vector<std::vector<std::int32_t>> two_vertices{{0, 5}};
  const models::Batch b = models::make_batch({&with}, two_vertices, {}, {});
  REQUIRE(b.prior.rows() == 2);
  for (int i = 0; i < 4; ++i) CHECK(b.prior.at(1, i) == with.prior.at(5, i));
  // A prior model refuses a batch without one, naming what is missing.
  models::ModelConfig cfg = models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(4), 4);
  auto model = models::make_model(cfg, 1);
  const models::Batch nb = models::make_batch({&without}, {{}}, {}, {});
  CHECK_THROWS_WITH(model->forward(nb, false), Catch::Contains("log prior"));
  // Configurations round-trip the key; ones written before it read as off.
  CHECK(models::ModelConfig::from_text(cfg.to_text()) == cfg);
  CHECK_FALSE(models::ModelConfig::from_text("name = skinweights-any\n").logit_prior);
  // New models read bone heat with its current rules; a config from before
  // the keys reads the bone heat its model was trained on.
  CHECK(cfg.prior_weight_limit);
  CHECK(cfg.prior_straight_chains);
  CHECK(prior_bone_heat(cfg).cut_below == BoneHeatParams{}.cut_below);
  CHECK(prior_bone_heat(cfg).continue_cos == BoneHeatParams{}.continue_cos);
  const models::ModelConfig old = models::ModelConfig::from_text("name = skinweights-any\nlogit_prior = true\n");
  CHECK(prior_bone_heat(old).cut_below == 0.0f);
  CHECK(prior_bone_heat(old).continue_cos > 1.0f);
  for (const bool limit : {false, true})
    for (const bool chains : {false, true}) {
      models::ModelConfig c = cfg;
      c.prior_weight_limit = limit;
      c.prior_straight_chains = chains;
      CHECK(models::ModelConfig::from_text(c.to_text()) == c);
    }
  cfg.pair_scorer = {8, 4};
  cfg.pair_features = kPairFeatures;
  CHECK(models::ModelConfig::from_text(cfg.to_text()) == cfg);
  // A pair scorer needs the slots' columns inside the input.
  cfg.pair_features = 100;
  CHECK_THROWS_WITH(models::make_model(cfg, 1), Catch::Contains("pair_features"));
}

TEST_CASE("skinweights-any's validation L1 is gat eval's L1 over the character's joints", "[skin_any]") {
  // With k = 2 candidates some vertices have artist weight on a third joint:
  // the target (renormalised over the candidates) alone would understate the
  // error there. Trainer::validate must give what evaluating the predicted
  // weights against the character's own weights gives.
  const PreparedCharacter pc = procedural(ProceduralKind::humanoid, 3);
  const int k = 2;
  BoneCandidates c;
  const models::Sample s = bone_candidate_sample(pc, k, new_model_heat(), &c);
  REQUIRE(s.target_mass.defined());
  int partial = 0, none = 0;
  for (std::int64_t v = 0; v < s.target_mass.rows(); ++v) {
    const float m = s.target_mass.at(v, 0);
    CHECK(m >= 0.0f);
    CHECK(m <= 1.0f + 1e-6f);
    partial += m < 0.999f;
    none += m == 0.0f;
  }
  INFO(partial << " vertices with weight outside their candidates, " << none << " with all of it");
  REQUIRE(partial > 0);
  models::ModelConfig cfg = small_any_config(k);
  auto model = models::make_model(cfg, 2);
  randomise_last_layer(*model, 3);
  const models::Normaliser norm = models::Normaliser::fit({s}, false);
  models::Trainer t(*model, models::TrainOptions::defaults_for(cfg), norm);
  const double l1 = t.validate({s}).weight_l1;

  const SkinWeights p = predict_skin_weights_any(*model, norm, pc, models::kEvaluationInfluences);
  const SkinWeights& w = pc.character.mesh.weights;
  const std::int64_t n = w.num_vertices(), J = pc.character.skeleton.num_joints();
  std::vector<float> pd(std::size_t(n * J), 0.0f), td(std::size_t(n * J), 0.0f);
  for (std::int64_t v = 0; v < n; ++v) {
    double total = 0;
    for (std::int64_t e = w.ptr[v]; e < w.ptr[v + 1]; ++e) total += w.weight[e];
    for (std::int64_t e = w.ptr[v]; e < w.ptr[v + 1]; ++e) td[std::size_t(v * J + w.joint[e])] += float(w.weight[e] / total);
    for (std::int64_t e = p.ptr[v]; e < p.ptr[v + 1]; ++e) pd[std::size_t(v * J + p.joint[e])] += p.weight[e];
  }
  const double want = weight_metrics(pd, td, J).l1_mean;
  CHECK(l1 == Approx(want).epsilon(1e-5));
  // The dominant bone likewise: gat eval's over the joints, including the
  // vertices whose artist's largest weight is on a joint that is not a
  // candidate (wrong whatever the model says).
  const int outside = int(std::count(s.target_dominant.begin(), s.target_dominant.end(), -1));
  INFO(outside << " vertices whose dominant joint is not a candidate");
  CHECK(outside > 0);
  const double dom = t.validate({s}).dominant;
  CHECK(dom == Approx(dominant_accuracy(pd, td, J)).epsilon(1e-12));
  CHECK(dom > 0.05);
  CHECK(dom < 1.0);
  // Without the mass the figure is the candidates' only, and lower: the test
  // tells the two apart.
  models::Sample candidates_only = s;
  candidates_only.target_mass = Tensor{};
  CHECK(t.validate({candidates_only}).weight_l1 < want - 1e-3);
}
