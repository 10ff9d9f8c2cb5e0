// Data parallelism without MPI (the mpirun tests are tests/dist/): the
// sharding rule, SyncBatchNorm with the batch split over threads that sum
// through a shared buffer (as ranks do through MPI), Dropout's mask windows,
// and a Trainer over a group of one being the plain single-process trainer.
#include <barrier>
#include <random>
#include <thread>

#include <catch2/catch.hpp>

#include "gatcore/batch_split.hpp"
#include "gatcore/dist/data_parallel.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/nn/dropout.hpp"
#include "src/backends/cpu/batchnorm.hpp"
#include "model_fixtures.hpp"
#include "test_util.hpp"

using namespace gatcore;

namespace {

// `parts` threads summing double vectors: each adds its copy into a shared
// buffer in thread order (a fixed order, like the ranks' ordered sum).
struct ThreadSum {
  explicit ThreadSum(int parts) : parts(parts), sync(parts) {}
  int parts;
  std::barrier<> sync;
  std::vector<double> acc;
  std::vector<std::vector<double>> copies;
  void sum(int me, double* v, std::size_t n) {
    if (me == 0) copies.assign(std::size_t(parts), {});
    sync.arrive_and_wait();
    copies[std::size_t(me)].assign(v, v + n);
    sync.arrive_and_wait();
    if (me == 0) {
      acc.assign(n, 0.0);
      for (const auto& c : copies)
        for (std::size_t i = 0; i < n; ++i) acc[i] += c[i];
    }
    sync.arrive_and_wait();
    std::copy(acc.begin(), acc.end(), v);
    sync.arrive_and_wait();
  }
};

Tensor rows_of(const Tensor& t, std::int64_t r0, std::int64_t r1) {
  Tensor o = Tensor::empty(r1 - r0, t.cols());
  for (std::int64_t i = r0; i < r1; ++i)
    for (std::int64_t j = 0; j < t.cols(); ++j) o.at(i - r0, j) = t.at(i, j);
  return o;
}

// Each part's outputs and input gradients are the whole batch's rows; its
// parameter gradients are its rows' shares, which add up to the whole's.
void check_parts_match_whole(const std::int64_t* cut, const std::vector<Tensor>& py, const std::vector<Tensor>& pdx,
                             const std::vector<Tensor>& pdg, const std::vector<Tensor>& pdb, const Tensor& y,
                             const Tensor& dx, const Tensor& dg, const Tensor& db) {
  const std::int64_t C = y.cols();
  for (int p = 0; p < 3; ++p)
    for (std::int64_t i = cut[p]; i < cut[p + 1]; ++i)
      for (std::int64_t c = 0; c < C; ++c) {
        CHECK(py[p].at(i - cut[p], c) == Approx(y.at(i, c)).margin(1e-5));
        CHECK(pdx[p].at(i - cut[p], c) == Approx(dx.at(i, c)).margin(1e-5));
      }
  for (std::int64_t c = 0; c < C; ++c) {
    CHECK(pdg[0].at(0, c) + pdg[1].at(0, c) + pdg[2].at(0, c) == Approx(dg.at(0, c)).margin(1e-4));
    CHECK(pdb[0].at(0, c) + pdb[1].at(0, c) + pdb[2].at(0, c) == Approx(db.at(0, c)).margin(1e-4));
  }
}

}  // namespace

TEST_CASE("share_of: contiguous shares in rank order cover the batch once, sizes differ by at most one") {
  for (std::size_t count : {0, 1, 2, 5, 12}) {
    for (int size : {1, 2, 3, 4, 7}) {
      std::size_t next = 0, lo = count, hi = 0;
      for (int r = 0; r < size; ++r) {
        const dist::Share s = dist::share_of(count, r, size);
        CHECK(s.begin == next);
        next = s.end;
        lo = std::min(lo, s.end - s.begin), hi = std::max(hi, s.end - s.begin);
      }
      CHECK(next == count);
      CHECK(hi - lo <= 1);
    }
  }
  CHECK_THROWS_WITH(dist::share_of(4, 2, 2), Catch::Contains("rank 2 of 2"));
}

TEST_CASE("SyncBatchNorm: a batch split over 3 parts gives the whole batch's statistics, outputs and gradients") {
  std::mt19937 rng(7);
  const std::int64_t n = 301, C = 19;
  const Tensor x = testutil::random_tensor(n, C, rng, -2.f, 3.f), dy = testutil::random_tensor(n, C, rng);
  const Tensor gamma = testutil::random_tensor(1, C, rng, 0.5f, 1.5f), beta = testutil::random_tensor(1, C, rng);
  // The whole batch in one call.
  Tensor y = Tensor::empty(n, C), sm = Tensor::empty(1, C), si = Tensor::empty(1, C);
  Tensor rm = Tensor::zeros(1, C), rv = Tensor::full(1, C, 1.f);
  cpu::batchnorm_train_forward(x, gamma, beta, 1e-5f, 0.1f, y, sm, si, rm, rv);
  Tensor dx = Tensor::zeros(n, C), dg = Tensor::zeros(1, C), db = Tensor::zeros(1, C);
  cpu::batchnorm_train_backward(x, gamma, sm, si, dy, dx, dg, db);
  // Three uneven parts, one thread each, summing through ThreadSum.
  const std::int64_t cut[4] = {0, 100, 101, n};  // a one-row part: only the whole batch needs 2 rows
  ThreadSum ts(3);
  std::vector<Tensor> py(3), pdx(3), pdg(3), pdb(3), prm(3), prv(3), psm(3), psi(3);
  std::vector<std::thread> threads;
  for (int p = 0; p < 3; ++p)
    threads.emplace_back([&, p] {
      const Tensor xp = rows_of(x, cut[p], cut[p + 1]), dyp = rows_of(dy, cut[p], cut[p + 1]);
      const std::int64_t m = xp.rows();
      py[p] = Tensor::empty(m, C), psm[p] = Tensor::empty(1, C), psi[p] = Tensor::empty(1, C);
      prm[p] = Tensor::zeros(1, C), prv[p] = Tensor::full(1, C, 1.f);
      const SumAcross across = [&ts, p](double* v, std::size_t k) { ts.sum(p, v, k); };
      cpu::batchnorm_train_forward(xp, gamma, beta, 1e-5f, 0.1f, py[p], psm[p], psi[p], prm[p], prv[p], across);
      pdx[p] = Tensor::zeros(m, C), pdg[p] = Tensor::zeros(1, C), pdb[p] = Tensor::zeros(1, C);
      cpu::batchnorm_train_backward(xp, gamma, psm[p], psi[p], dyp, pdx[p], pdg[p], pdb[p], across);
    });
  for (auto& t : threads) t.join();
  for (int p = 0; p < 3; ++p) {
    for (std::int64_t c = 0; c < C; ++c) {
      // Statistics in double, summed in another grouping: equal to float rounding.
      CHECK(psm[p].at(0, c) == Approx(sm.at(0, c)).margin(1e-6));
      CHECK(psi[p].at(0, c) == Approx(si.at(0, c)).epsilon(1e-6));
      CHECK(prm[p].at(0, c) == Approx(rm.at(0, c)).margin(1e-6));
      CHECK(prv[p].at(0, c) == Approx(rv.at(0, c)).epsilon(1e-6));
    }
  }
  check_parts_match_whole(cut, py, pdx, pdg, pdb, y, dx, dg, db);
}

TEST_CASE("SyncBatchNorm fused with LeakyReLU: a batch split over 3 parts gives the whole batch's outputs and "
          "gradients") {
  std::mt19937 rng(8);
  const std::int64_t n = 301, C = 11;
  const Tensor x = testutil::random_tensor(n, C, rng, -2.f, 3.f), dy = testutil::random_tensor(n, C, rng);
  const Tensor gamma = testutil::random_tensor(1, C, rng, -1.5f, 1.5f), beta = testutil::random_tensor(1, C, rng);
  const Activation f = Activation::leaky_relu;
  auto fused = [&](const Tensor& xp, const Tensor& dyp, Tensor& y, Tensor& dx, Tensor& dg, Tensor& db,
                   const SumAcross& across) {
    const std::int64_t m = xp.rows();
    Tensor sm = Tensor::empty(1, C), si = Tensor::empty(1, C), af = Tensor::empty(2, C);
    y = Tensor::empty(m, C), dx = Tensor::zeros(m, C), dg = Tensor::zeros(1, C), db = Tensor::zeros(1, C);
    cpu::batchnorm_act_train_forward(xp, gamma, beta, 1e-5f, 0.1f, f, 0.1f, y, sm, si, af, Tensor(), Tensor(), across);
    cpu::batchnorm_act_train_backward(xp, gamma, beta, f, 0.1f, sm, si, af, dyp, dx, dg, db, across);
  };
  Tensor y, dx, dg, db;
  fused(x, dy, y, dx, dg, db, {});
  const std::int64_t cut[4] = {0, 100, 101, n};
  ThreadSum ts(3);
  std::vector<Tensor> py(3), pdx(3), pdg(3), pdb(3);
  std::vector<std::thread> threads;
  for (int p = 0; p < 3; ++p)
    threads.emplace_back([&, p] {
      fused(rows_of(x, cut[p], cut[p + 1]), rows_of(dy, cut[p], cut[p + 1]), py[p], pdx[p], pdg[p], pdb[p],
            [&ts, p](double* v, std::size_t k) { ts.sum(p, v, k); });
    });
  for (auto& t : threads) t.join();
  check_parts_match_whole(cut, py, pdx, pdg, pdb, y, dx, dg, db);
}

TEST_CASE("Dropout under a batch split: each part's mask is its rows of the whole batch's, the stream ends alike") {
  std::mt19937 rng(3);
  const Var x(testutil::random_tensor(40, 7, rng));
  nn::Rng whole(99);
  const Tensor y = nn::Dropout{0.5f}.forward(x, true, whole).value();
  const std::int64_t cut[3] = {0, 15, 40};
  for (int p = 0; p < 2; ++p) {
    nn::Rng part(99);
    BatchSplit split;
    split.row_begin = cut[p], split.rows = cut[p + 1] - cut[p], split.global_rows = 40;
    BatchSplitScope scope(split);
    const Tensor yp = nn::Dropout{0.5f}.forward(Var(rows_of(x.value(), cut[p], cut[p + 1])), true, part).value();
    for (std::int64_t i = cut[p]; i < cut[p + 1]; ++i)
      for (std::int64_t j = 0; j < 7; ++j) REQUIRE(yp.at(i - cut[p], j) == y.at(i, j));
    CHECK(part.next() == nn::Rng(whole).next());
  }
  // A placeholder share draws through the whole stream and drops nothing.
  nn::Rng ph(99);
  BatchSplit split;
  split.row_begin = 40, split.rows = 0, split.global_rows = 40;
  BatchSplitScope scope(split);
  const Tensor yp = nn::Dropout{0.5f}.forward(Var(rows_of(x.value(), 0, 5)), true, ph).value();
  for (std::int64_t i = 0; i < 5; ++i)
    for (std::int64_t j = 0; j < 7; ++j) CHECK(yp.at(i, j) == x.value().at(i, j));
  CHECK(ph.next() == nn::Rng(whole).next());
}

TEST_CASE("Trainer over a group of one is the single-process trainer, bit for bit") {
  using namespace gatcore::models;
  std::vector<Sample> train;
  for (int k = 0; k < 6; ++k) train.push_back(fixtures::wave_sample(8, 7, 0.4f * float(k), true, 5));
  const ModelConfig cfg = ModelConfig::defaults("fc", 9, 5);
  auto a = make_model(cfg, 1), b = make_model(cfg, 1);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.batch_size = 4, o.sample_vertices = 20;
  auto single = dist::make_single_process();
  Trainer ta(*a, o, Normaliser::fit(train, false)), tb(*b, o, Normaliser::fit(train, false), *single);
  CHECK(&ta.communicator() == &dist::world());
  CHECK(dist::world().size() == 1);  // not launched by mpirun
  const EpochStats sa = ta.run_epoch(train, train), sb = tb.run_epoch(train, train);
  CHECK(sa.train_loss == sb.train_loss);
  CHECK(sa.val_loss == sb.val_loss);
  CHECK(sa.comm_bytes == 0);
  for (std::size_t k = 0; k < a->registry().params.size(); ++k)
    CHECK(a->registry().params[k].var.value().to_vector() == b->registry().params[k].var.value().to_vector());
}

namespace {
// Rank `r` of `n` for code that asks who it is but does not communicate.
struct NamedRank final : dist::Communicator {
  NamedRank(int r, int n) : r(r), n(n) {}
  int r, n;
  int rank() const override { return r; }
  int size() const override { return n; }
  void sum(float*, std::size_t) override { FAIL("no communication expected"); }
  void sum(double*, std::size_t) override { FAIL("no communication expected"); }
  void broadcast(void*, std::size_t, int) override { FAIL("no communication expected"); }
  void barrier() override {}
  [[noreturn]] void abort(const std::string& m, int) override { throw Error(m); }
  std::size_t bytes_sent() const override { return 0; }
  double seconds_in_collectives() const override { return 0; }
};
}  // namespace

TEST_CASE("samples_needed: every sample of the epoch is some rank's, each rank needs about its share") {
  using namespace gatcore::models;
  std::vector<Sample> train{fixtures::wave_sample(6, 5, 0.f, true, 5)};
  const ModelConfig cfg = ModelConfig::defaults("fc", 9, 5);
  auto m = make_model(cfg, 1);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.batch_size = 4;
  const std::size_t count = 22;  // batches of 4, 4, 4, 4, 4, 2
  for (int n : {1, 2, 3, 4, 8}) {
    std::vector<int> owners(count, 0);
    for (int r = 0; r < n; ++r) {
      NamedRank g(r, n);
      Trainer t(*m, o, Normaliser::fit(train, false), g);
      const std::vector<bool> need = t.samples_needed(count);
      REQUIRE(need.size() == count);
      std::size_t mine = 0;
      for (std::size_t i = 0; i < count; ++i) owners[i] += need[i], mine += need[i];
      // Its shares (at most ⌈4/n⌉ of each batch), plus one placeholder per batch it has none of.
      CHECK(mine <= 6 * std::size_t((4 + n - 1) / n));
    }
    for (std::size_t i = 0; i < count; ++i) CHECK(owners[i] >= 1);
    if (n == 1) CHECK(std::count(owners.begin(), owners.end(), 1) == std::ptrdiff_t(count));
  }
}
