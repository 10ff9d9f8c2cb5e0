#include "gatcore/models/distill.hpp"

#include "gatcore/models/train.hpp"

namespace gatcore::models {

void distill_targets(Model& teacher, const Normaliser& teacher_norm, std::vector<Sample>& samples, float hard) {
  const ModelConfig& c = teacher.config();
  GATCORE_CHECK(c.task == Task::displacement, "distill: the teacher '", c.name, "' predicts ", task_name(c.task),
                ", not displacements");
  GATCORE_CHECK(hard >= 0.f && hard <= 1.f, "distill: the ground-truth weight must be in [0, 1], got ", hard);
  for (Sample& s : samples) {
    GATCORE_CHECK(s.features.cols() == c.in_dim, "distill: sample '", s.name, "' has ", s.features.cols(),
                  " features, the teacher takes ", c.in_dim);
    GATCORE_CHECK(hard == 0.f || s.target.defined(), "distill: sample '", s.name,
                  "' has no target to blend with the teacher's");
    const Tensor t = predict(teacher, s, teacher_norm);
    if (hard == 0.f) {
      s.target = t;
      continue;
    }
    check_shape(s.target, t.rows(), t.cols(), "distill: target");
    Tensor mixed = Tensor::empty(t.rows(), t.cols());
    for (std::int64_t i = 0; i < t.rows(); ++i)
      for (std::int64_t j = 0; j < t.cols(); ++j)
        mixed.at(i, j) = (1.f - hard) * t.at(i, j) + hard * s.target.at(i, j);
    s.target = mixed;
  }
}

}  // namespace gatcore::models
