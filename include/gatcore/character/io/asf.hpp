#pragma once
// Acclaim ASF (skeleton) / AMC (motion) import: the CMU motion capture
// database's own format.
#include <string>
#include <string_view>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/progress.hpp"

namespace gatcore::character {

// The skeleton of an ASF file: the root, then one joint per bone (named as
// the bone) at the bone's start, parents before children; rest = every dof
// at zero, joint frames aligned with the file's axes. Lengths and positions
// are divided by `:units length` (Acclaim's length scale: CMU files come out
// in inches). Throws InvalidArgument naming the file, the line and the field
// for anything malformed (unknown section or bone field, a dof listed twice,
// limits not matching the dofs or lo > hi, an axis order that is not a
// permutation of XYZ, a bone outside :hierarchy or under two parents, a
// cycle, non-finite numbers).
Skeleton parse_asf(std::string_view asf, const std::string& asf_path);

// A motion from an ASF skeleton and an AMC file: one pose per AMC frame;
// each bone's local rotation is C M C^-1 (C: its `axis` angles in their
// order, M: its dof values in the dof order), the root's translation the
// TX TY TZ values. A bone missing from a frame keeps its previous values
// (zero in the first). fps: 120 (the CMU capture rate; AMC files do not
// store one) unless `fps` > 0. Throws InvalidArgument naming the AMC file,
// the line and the field (unknown bone, wrong number of values, a value
// before the first frame number, no frames, non-finite numbers).
Motion parse_asf_amc(std::string_view asf, const std::string& asf_path, std::string_view amc,
                     const std::string& amc_path, float fps = 0.0f, const WarningFn& warn = {});
Motion load_asf_amc(const std::string& asf_path, const std::string& amc_path, float fps = 0.0f,
                    const WarningFn& warn = {});

}  // namespace gatcore::character
