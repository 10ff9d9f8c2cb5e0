#pragma once
// Distillation: a compact student model (e.g. Ori.GAT, ~14k parameters)
// trained to imitate a large teacher (paper-size DenseGATs, ~714k) on the
// teacher's own data: the student's targets are the teacher's predictions on
// the very same samples (vertex windows, poses), optionally blended with the
// ground truth. The teacher's answers are smoother than the raw Delta Mush
// targets (it has already averaged over the training set), which is what
// makes a much smaller model close to it.
#include <vector>

#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::models {

// Replaces every sample's target by (1 - hard) * teacher + hard * target,
// teacher = models::predict(teacher, sample, teacher_norm) (eval mode, in the
// targets' units). hard in [0, 1]; hard > 0 needs the samples' targets. The
// teacher must predict displacements with the samples' feature width.
void distill_targets(Model& teacher, const Normaliser& teacher_norm, std::vector<Sample>& samples, float hard = 0.f);

}  // namespace gatcore::models
