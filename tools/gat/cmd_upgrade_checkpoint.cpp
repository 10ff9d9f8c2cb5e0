// `gat upgrade-checkpoint OLD.gcm -o NEW.gcm`: rewrites a checkpoint of
// format version 1 as version 2 (models/checkpoint.hpp upgrade_checkpoint).
// Version-1 checksums covered the data section only, so loaders refuse those
// files (an edited header went unnoticed); this command verifies the data
// against that checksum, checks that a model loads from it, and writes the
// file with the version-2 checksum over metadata and tensors.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "gatcore/models/checkpoint.hpp"

namespace gat {

namespace {

struct UpgradeArgs {
  std::string in, out;
};

int run_upgrade(const UpgradeArgs& a) {
  const int version = gatcore::models::upgrade_checkpoint(a.in, a.out);
  std::printf("gat upgrade-checkpoint: %s (format version %d, data checksum verified) -> %s (format version 2)\n",
              a.in.c_str(), version, a.out.c_str());
  return 0;
}

}  // namespace

Runner setup_upgrade_checkpoint(CLI::App& gat) {
  auto a = std::make_shared<UpgradeArgs>();
  CLI::App& c = add_command(gat, "upgrade-checkpoint", "rewrite a checkpoint of format version 1 as version 2");
  set_details(c, "Version-1 checkpoints (written before the checksum covered the metadata) are refused by every "
                 "command. This verifies OLD's data against its version-1 checksum, checks that a model loads from "
                 "it, and writes it as version 2. Version 1 could not detect an edited header: upgrade only files "
                 "you trust.");
  c.add_option("OLD", a->in, "the checkpoint (.gcm) to upgrade")->required();
  add_out(c, a->out, "the upgraded checkpoint (may be OLD itself)")->required();
  return [a] { return run_upgrade(*a); };
}

}  // namespace gat
