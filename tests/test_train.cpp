// Trainer pieces: vertex sampling, block-diagonal batches with neighbour
// graphs, schedules, determinism.
#include <catch2/catch.hpp>

#include <cmath>

#include <set>

#include <omp.h>

#include "gatcore/models/train.hpp"
#include "model_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::models;

TEST_CASE("vertex sampling: consecutive runs, random distinct vertices, full meshes") {
  nn::Rng rng(1);
  auto c = sample_vertices(5000, Sampling::consecutive, 1000, rng);
  REQUIRE(c.size() == 1000);
  for (std::size_t k = 1; k < c.size(); ++k) CHECK(c[k] == c[k - 1] + 1);
  CHECK(c.back() < 5000);
  auto r = sample_vertices(5000, Sampling::random, 2048, rng);
  REQUIRE(r.size() == 2048);
  CHECK(std::set<std::int32_t>(r.begin(), r.end()).size() == 2048);
  CHECK(std::is_sorted(r.begin(), r.end()));
  CHECK(sample_vertices(300, Sampling::random, 2048, rng).size() == 300);  // small mesh: everything
  CHECK(sample_vertices(300, Sampling::full, 10, rng).size() == 300);
  nn::Rng a(9), b(9);
  CHECK(sample_vertices(5000, Sampling::random, 100, a) == sample_vertices(5000, Sampling::random, 100, b));
}

TEST_CASE("paper training defaults per model family") {
  auto dg = TrainOptions::defaults_for(ModelConfig::defaults("densegats", 71));
  CHECK(dg.batch_size == 8);
  CHECK(dg.sampling == Sampling::consecutive);
  CHECK(dg.sample_vertices == 1000);
  CHECK(dg.schedule == Schedule::plateau);
  CHECK(dg.plateau_factor == 0.75f);
  CHECK(dg.plateau_patience == 8);
  CHECK(dg.min_lr == 5e-7f);
  auto ns = TrainOptions::defaults_for(ModelConfig::defaults("neuroskinning", 71, 30));
  CHECK(ns.batch_size == 12);
  CHECK(ns.sampling == Sampling::random);
  CHECK(ns.sample_vertices == 2048);
  CHECK(ns.schedule == Schedule::step);
  CHECK(ns.step_gamma == 0.99f);
  CHECK(ns.step_every == 200);
}

TEST_CASE("ReduceLROnPlateau: factor after patience bad epochs, floored at min lr") {
  PlateauScheduler p{0.75f, 5e-7f, 2};
  float lr = 1e-3f;
  lr = p.step(1.f, lr);
  lr = p.step(1.f, lr);
  lr = p.step(1.f, lr);
  CHECK(lr == 1e-3f);
  lr = p.step(1.f, lr);  // third bad epoch > patience 2
  CHECK(lr == Approx(7.5e-4f));
  lr = p.step(0.5f, lr);  // improvement resets
  CHECK(p.bad_epochs == 0);
  for (int k = 0; k < 400; ++k) lr = p.step(0.9f, lr);
  CHECK(lr == 5e-7f);
}

TEST_CASE("ReduceLROnPlateau with validation every few epochs compares validation losses only") {
  ModelConfig c = ModelConfig::defaults("densegats", 9, 3);
  c.modules = 1;
  c.blocks = 1;
  std::vector<Sample> train = {fixtures::wave_sample(8, 6, 0.f, false), fixtures::wave_sample(8, 6, 0.5f, false)};
  std::vector<Sample> val = {fixtures::wave_sample(7, 6, 1.f, false)};
  auto m = make_model(c, 3);
  TrainOptions o = TrainOptions::defaults_for(c);
  o.sample_vertices = 25;
  o.batch_size = 2;
  o.plateau_patience = 0;  // any epoch that is not an improvement lowers the lr
  Trainer t(*m, o, Normaliser::fit(train, true));
  t.run_epoch(train);  // no validation yet: the training loss is the metric
  CHECK(t.plateau().has_best);
  CHECK_FALSE(t.plateau().on_validation);
  const EpochStats v = t.run_epoch(train, val);
  CHECK(t.plateau().on_validation);
  CHECK(t.plateau().best == float(v.val_loss));  // a fresh best, not compared with the training loss
  const float lr = t.optimiser().lr();
  for (int e = 0; e < 3; ++e) t.run_epoch(train);  // epochs without validation leave it alone
  CHECK(t.optimiser().lr() == lr);
  CHECK(t.plateau().best == float(v.val_loss));
}

TEST_CASE("cosine schedule: the rate falls from lr0 to the floor over the run; the Trainer leaves it alone") {
  CHECK(cosine_lr(1e-3f, 1e-5f, 0.0) == Approx(1e-3f));
  CHECK(cosine_lr(1e-3f, 1e-5f, 0.5) == Approx(0.5 * (1e-3 + 1e-5)));
  CHECK(cosine_lr(1e-3f, 1e-5f, 1.0) == Approx(1e-5f));
  CHECK(cosine_lr(1e-3f, 1e-5f, 7.0) == Approx(1e-5f));   // past the budget: the floor, not a rise
  CHECK(cosine_lr(1e-3f, 1e-5f, -1.0) == Approx(1e-3f));
  float prev = 1.f;
  for (int k = 0; k <= 20; ++k) {
    const float lr = cosine_lr(1e-3f, 0.f, k / 20.0);
    CHECK(lr <= prev);
    prev = lr;
  }
  CHECK(schedule_from_name("cosine") == Schedule::cosine);
  CHECK(std::string(schedule_name(Schedule::step)) == "step");
  CHECK_THROWS_WITH(schedule_from_name("linear", "ckpt.gcm: metadata lr_schedule"),
                    Catch::Contains("ckpt.gcm: metadata lr_schedule") && Catch::Contains("'linear'"));

  ModelConfig c = ModelConfig::defaults("densegats", 9, 3);
  c.modules = 1;
  c.blocks = 1;
  std::vector<Sample> train = {fixtures::wave_sample(8, 6, 0.f, false), fixtures::wave_sample(8, 6, 0.5f, false)};
  auto m = make_model(c, 3);
  TrainOptions o = TrainOptions::defaults_for(c);
  o.sample_vertices = 25;
  o.batch_size = 2;
  o.schedule = Schedule::cosine;
  o.plateau_patience = 0;  // would lower the rate every epoch under the plateau rule
  Trainer t(*m, o, Normaliser::fit(train, true));
  t.optimiser().set_lr(3e-4f);
  for (int e = 0; e < 3; ++e) {
    const EpochStats st = t.run_epoch(train, train);
    CHECK(st.lr == 3e-4f);
  }
}

TEST_CASE("batches: induced subgraphs stacked block-diagonally with per-character neighbour graphs") {
  Sample a = fixtures::wave_sample(6, 5, 0.f, true), b = fixtures::wave_sample(5, 4, 1.f, true);
  a.bone_mask = Tensor::from(1, 5, {1, 1, 1, 0, 1});
  std::vector<std::int32_t> sa = {0, 1, 2, 6, 7, 8}, sb = {};
  Batch bt = make_batch({&a, &b}, {sa, sb}, Normaliser{}, {3, 4});
  CHECK(bt.graph->num_nodes == 6 + 20);
  CHECK(bt.graph->segment_ptr == std::vector<std::int64_t>{0, 6, 26});
  CHECK(bt.x.at(3, 0) == a.features.at(6, 0));
  CHECK(bt.target.at(10, 2) == b.target.at(4, 2));
  REQUIRE(bt.neighbours.count(3));
  const CsrGraph& n3 = *bt.neighbours.at(3);
  for (std::int64_t i = 0; i < n3.num_nodes; ++i) {
    CHECK(n3.degree(i) == 3);
    for (std::int64_t e = n3.indptr[i]; e < n3.indptr[i + 1]; ++e)
      CHECK((i < 6) == (n3.indices[std::size_t(e)] < 6));  // never crosses characters
  }
  // Different masks -> per-row mask; b has none -> all ones.
  REQUIRE(bt.mask.rows() == 26);
  CHECK(bt.mask.at(0, 3) == 0.f);
  CHECK(bt.mask.at(10, 3) == 1.f);
  // Given geodesic neighbour lists are restricted to the selection.
  a.geodesic_neighbours = hop_neighbours(*a.graph, 10);
  Batch g = make_batch({&a}, {sa}, Normaliser{}, {4});
  CHECK(g.neighbours.at(4)->num_nodes == 6);
  CHECK(g.neighbours.at(4)->degree(0) == 4);
}

TEST_CASE("training is deterministic given a seed") {
  for (const std::string name : {"densegats", "neuroskinning", "fc"}) {
    INFO("model " << name);
    ModelConfig c = ModelConfig::defaults(name, 9, name == "densegats" ? 3 : 5);
    const bool w = c.task == Task::weights;
    std::vector<Sample> data = {fixtures::wave_sample(8, 6, 0.f, w), fixtures::wave_sample(8, 6, 0.5f, w),
                                fixtures::wave_sample(7, 6, 1.f, w)};
    if (name == "densegats") {
      c.modules = 1;
      c.blocks = 2;
    }
    auto run = [&](std::uint64_t seed) {
      auto m = make_model(c, seed);
      TrainOptions o = TrainOptions::defaults_for(c);
      o.sample_vertices = 25;
      o.batch_size = 2;
      o.seed = seed;
      Trainer t(*m, o, Normaliser::fit(data, c.task == Task::displacement));
      for (int e = 0; e < 3; ++e) t.run_epoch(data);
      std::vector<float> all;
      for (const auto& p : m->registry().params) {
        auto v = p.var.value().to_vector();
        all.insert(all.end(), v.begin(), v.end());
      }
      return all;
    };
    const auto a = run(7), b = run(7), d = run(8);
    CHECK(a == b);
    CHECK(a != d);
    // Every kernel reduces in a fixed order independent of the thread count.
    const int nt = omp_get_max_threads();
    omp_set_num_threads(nt == 1 ? 2 : 1);
    const auto e = run(7);
    omp_set_num_threads(nt);
    CHECK(a == e);
  }
}

TEST_CASE("Normaliser: z-scores, and a column constant in training stays at its training value") {
  // Column 1 is 0 in every training row (the distance column of a bone no
  // training character has): a new character that fills it must not feed
  // the untrained weights behind it.
  Sample s;
  s.features = Tensor::empty(4, 3);
  for (std::int64_t i = 0; i < 4; ++i) {
    s.features.at(i, 0) = float(i);  // mean 1.5, std sqrt(1.25)
    s.features.at(i, 1) = 0.f;
    s.features.at(i, 2) = 2.f;
  }
  s.target = Tensor::zeros(4, 3);
  const Normaliser n = Normaliser::fit({s}, false);
  CHECK(n.mean.at(0, 0) == Approx(1.5));
  CHECK(n.inv_std.at(0, 0) == Approx(1.0 / std::sqrt(1.25)));
  CHECK(n.inv_std.at(0, 1) == 0.f);
  CHECK(n.inv_std.at(0, 2) == 0.f);
  Tensor x = Tensor::empty(1, 3);
  x.at(0, 0) = 3.f, x.at(0, 1) = 0.7f, x.at(0, 2) = 5.f;
  const Tensor y = n.apply(x);
  CHECK(y.at(0, 0) == Approx(1.5 / std::sqrt(1.25)));
  CHECK(y.at(0, 1) == 0.f);  // held at the training value, whatever the new character puts there
  CHECK(y.at(0, 2) == 0.f);
}

TEST_CASE("validation of a skin-weight model reports the top-4 weights' L1 beside the loss") {
  // The L1 is what --keep-best-by l1 selects on; it must be the figure a user
  // computes from predict(..., top_k = 4) against the targets, per sample
  // averaged over the samples.
  ModelConfig c = ModelConfig::defaults("neuroskinning", 9, 6);
  auto m = make_model(c, 5);
  std::vector<Sample> train = {fixtures::wave_sample(8, 6, 0.f, true, 6)};
  std::vector<Sample> val = {fixtures::wave_sample(7, 6, 1.f, true, 6), fixtures::wave_sample(9, 5, 0.4f, true, 6)};
  TrainOptions o = TrainOptions::defaults_for(c);
  o.sample_vertices = 30;
  const Normaliser norm = Normaliser::fit(train, false);
  Trainer t(*m, o, norm);
  const EpochStats st = t.run_epoch(train, val);
  double want = 0, want_dominant = 0;
  for (const Sample& s : val) {
    const Tensor w = predict(*m, s, norm, kEvaluationInfluences);
    double sum = 0;
    std::int64_t right = 0;
    for (std::int64_t i = 0; i < w.rows(); ++i) {
      int nonzero = 0;
      std::int64_t pw = 0, pt = 0;
      for (std::int64_t j = 0; j < w.cols(); ++j) {
        sum += std::abs(double(w.at(i, j)) - double(s.target.at(i, j)));
        nonzero += w.at(i, j) > 0.f;
        if (w.at(i, j) > w.at(i, pw)) pw = j;
        if (s.target.at(i, j) > s.target.at(i, pt)) pt = j;
      }
      CHECK(nonzero <= kEvaluationInfluences);
      right += pw == pt;
    }
    want += sum / double(w.rows()) / double(val.size());
    want_dominant += double(right) / double(w.rows()) / double(val.size());
  }
  // The dominant bone: the largest predicted weight on the target's largest.
  CHECK(st.val_dominant == Approx(want_dominant).epsilon(1e-12));
  CHECK(st.val_dominant > 0.0);
  CHECK(st.val_dominant < 1.0);
  REQUIRE(st.val_l1 >= 0);
  CHECK(st.val_l1 == Approx(want).epsilon(1e-5));
  CHECK(st.val_l1 > 0.05);  // 6 bones, targets spread over more than 4 of them: not 0 by accident
  const Evaluation e = t.validate(val);
  CHECK(e.loss == Approx(st.val_loss).epsilon(1e-9));
  CHECK(e.weight_l1 == Approx(st.val_l1).epsilon(1e-9));
  CHECK(e.dominant == st.val_dominant);
  CHECK(t.evaluate(val) == e.loss);

  // Displacement models have no L1: -1, and the epoch reports none.
  ModelConfig d = ModelConfig::defaults("densegats", 9, 3);
  d.modules = 1;
  d.blocks = 1;
  auto md = make_model(d, 3);
  std::vector<Sample> dtrain = {fixtures::wave_sample(8, 6, 0.f, false)};
  TrainOptions od = TrainOptions::defaults_for(d);
  od.sample_vertices = 25;
  Trainer td(*md, od, Normaliser::fit(dtrain, true));
  const EpochStats ds = td.run_epoch(dtrain, {fixtures::wave_sample(7, 6, 1.f, false)});
  CHECK(ds.val_l1 == -1);
  CHECK(ds.val_dominant == -1);
}
