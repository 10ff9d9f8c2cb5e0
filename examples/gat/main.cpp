// `gat` — gatcore's command-line tool: `gat <command> [options]`.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "commands.hpp"
#include "gatcore/dist/communicator.hpp"

namespace {

constexpr gat::Command kCommands[] = {
    {"demo", gat::cmd_demo, "train a small DenseGATs on the embedded tube character, compare with LBS"},
    {"train", gat::cmd_train, "train a model by name (densegats, neuroskinning, ...)"},
    {"eval", gat::cmd_eval, "evaluate a checkpoint"},
    {"info", gat::cmd_info, "print what a character (.glb/.gltf/.fbx/.dae), motion (.bvh) or dataset (.json) holds"},
    {"errormap", gat::cmd_errormap, "render where LBS departs from the reference deformer (Delta Mush) as a PNG"},
    {"dataset", gat::cmd_dataset, "build a dataset description (characters, motions, split, reference deformer)"},
    {"predict-weights", gat::cmd_predict_weights, "skin weights for a character from a NeuroSkinning-family model"},
    {"deform", gat::cmd_deform, "a motion on a character with DenseGATs corrections, baked as morph targets / .pc2"},
};

int usage(int rc) {
  std::FILE* out = rc ? stderr : stdout;
  std::fprintf(out, "usage: gat <command> [options]   (gat <command> --help for its options)\n\ncommands:\n");
  for (const auto& c : kCommands) std::fprintf(out, "  %-16s %s\n", c.name, c.summary);
  return rc;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(2);
  if (!std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "--help")) return usage(0);
  for (const auto& c : kCommands) {
    if (std::strcmp(argv[1], c.name)) continue;
    try {
      return c.run(argc - 1, argv + 1);
    } catch (const std::exception& e) {
      // One of several MPI ranks: end them all (they may be waiting for this
      // one in a collective), naming the rank.
      if (gatcore::dist::launched_by_mpi() && gatcore::dist::world().size() > 1) {
        auto& w = gatcore::dist::world();
        w.abort("gat " + std::string(c.name) + ": rank " + std::to_string(w.rank()) + " of " +
                    std::to_string(w.size()) + ": " + e.what() + " (stopping all ranks)",
                1);
      }
      std::fprintf(stderr, "gat %s: %s\n", c.name, e.what());
      return 1;
    }
  }
  std::fprintf(stderr, "gat: unknown command '%s'\n", argv[1]);
  return usage(2);
}
