// dist_trainer MODEL OUT: the library's Trainer on 10 procedural characters
// (batches of 4, 4 and 2: at 4 ranks the last batch leaves two ranks a
// placeholder share), 3 steps, run under `mpirun -np N` or alone
// (tests/dist/dist_train.sh compares the ranks' results with one process's).
// Rank 0 writes OUT.txt (the initial validation loss, each step's loss, the
// final validation loss, %.17g), OUT.gradS.gcm (step S's summed
// gradients) and OUT.gcm (the checkpoint after 3 steps).
#include <cstdio>
#include <exception>
#include <string>

#include "gatcore/dist/communicator.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "model_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::models;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: dist_trainer MODEL OUT\n");
    return 2;
  }
  const std::string name = argv[1], out = argv[2];
  dist::Communicator& comm = dist::world();
  try {
    const bool weights = models::uses_neuroskinning_features(models::model_kind_from_name(name));
    std::vector<Sample> train, val;
    for (int k = 0; k < 10; ++k)
      train.push_back(fixtures::wave_sample(9 + k % 3, 8 + k % 2, 0.3f * float(k), weights, 5, "t" + std::to_string(k)));
    for (int k = 0; k < 5; ++k)
      val.push_back(fixtures::wave_sample(10, 9, 0.25f + 0.5f * float(k), weights, 5, "v" + std::to_string(k)));
    ModelConfig cfg = ModelConfig::defaults(name, 9, weights ? 5 : 3);
    // The papers' structure (BatchNorm, pooling, attention, Dropout) at test widths: seconds, not minutes.
    cfg.stage1 = {32, 32};
    cfg.global_mlp = {64, 128};
    cfg.classifier = {128, 64};
    cfg.modules = 2;
    cfg.blocks = 3;
    cfg.head = {64, 32};
    cfg.fc = {128, 64, 64, 32};
    auto model = make_model(cfg, 11);
    TrainOptions opt = TrainOptions::defaults_for(cfg);
    opt.batch_size = 4;
    opt.sample_vertices = 48;
    opt.seed = 5;
    Trainer t(*model, opt, Normaliser::fit(train, !weights), comm);
    const double val0 = t.evaluate(val);  // sharded over the ranks; the same bits as one process
    std::vector<double> losses;
    std::vector<CheckpointFile> grads;
    const EpochStats st = t.run_epoch(train, val, [&](int, std::int64_t b, std::int64_t, double loss) {
      losses.push_back(loss);
      // After the step: the gradients summed over the ranks are still there.
      grads.emplace_back();
      for (const auto& p : model->registry().params)
        if (p.var.grad().defined()) grads.back().tensors.emplace_back(p.name, p.var.grad().clone());
      (void)b;
    });
    if (comm.rank() == 0) {
      std::FILE* f = std::fopen((out + ".txt").c_str(), "w");
      std::fprintf(f, "val0 %.17g\n", val0);
      for (std::size_t k = 0; k < losses.size(); ++k) std::fprintf(f, "loss%zu %.17g\n", k + 1, losses[k]);
      std::fprintf(f, "val %.17g\n", st.val_loss);
      std::fclose(f);
      for (std::size_t k = 0; k < grads.size(); ++k)
        write_checkpoint_file(out + ".grad" + std::to_string(k + 1) + ".gcm", grads[k]);
      save_checkpoint(out + ".gcm", *model, t.normaliser(), &t);
    }
    return 0;
  } catch (const std::exception& e) {
    comm.abort("dist_trainer: rank " + std::to_string(comm.rank()) + ": " + e.what(), 1);
  }
}
