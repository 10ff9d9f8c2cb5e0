#include "gatcore/character/deform/reference_deformer.hpp"

#include "gatcore/error.hpp"

namespace gatcore::character {

const char* reference_kind_name(ReferenceKind k) {
  return k == ReferenceKind::arap ? "arap" : k == ReferenceKind::files ? "files" : "delta_mush";
}

ReferenceKind parse_reference_kind(const std::string& name, const std::string& what) {
  if (name == "delta_mush") return ReferenceKind::delta_mush;
  if (name == "arap") return ReferenceKind::arap;
  if (name == "files") return ReferenceKind::files;
  throw InvalidArgument(what + ": unknown reference deformer '" + name + "' (known: delta_mush, arap, files)");
}

namespace {

class DeltaMushReference final : public ReferenceTargets {
 public:
  DeltaMushReference(const Mesh& mesh, const DeltaMushParams& p) : dm_(delta_mush_bind(mesh, p)) {}
  ReferenceKind kind() const override { return ReferenceKind::delta_mush; }
  std::vector<float> deform(std::span<const float> lbs, std::int32_t) const override {
    return delta_mush_apply(dm_, lbs);
  }

 private:
  DeltaMush dm_;
};

class ArapReference final : public ReferenceTargets {
 public:
  ArapReference(const Mesh& mesh, const ArapParams& p) : b_(arap_bind(mesh, p)) {}
  ReferenceKind kind() const override { return ReferenceKind::arap; }
  std::vector<float> deform(std::span<const float> lbs, std::int32_t) const override { return arap_apply(b_, lbs); }

 private:
  ArapBinding b_;
};

class FileReference final : public ReferenceTargets {
 public:
  FileReference(std::vector<std::vector<float>> f, std::string source) : frames_(std::move(f)), source_(std::move(source)) {}
  ReferenceKind kind() const override { return ReferenceKind::files; }
  std::int32_t num_frames() const override { return static_cast<std::int32_t>(frames_.size()); }
  std::vector<float> deform(std::span<const float> lbs, std::int32_t frame) const override {
    GATCORE_CHECK(frame >= 0 && frame < num_frames(), source_, ": no target for ",
                  frame < 0 ? std::string("a pose outside its frames (file targets have no random poses)")
                            : "frame " + std::to_string(frame) + " of " + std::to_string(num_frames()));
    const std::vector<float>& t = frames_[std::size_t(frame)];
    GATCORE_CHECK(t.size() == lbs.size(), source_, ": frame ", frame, " has ", t.size() / 3, " vertices, the pose ",
                  lbs.size() / 3);
    return t;
  }

 private:
  std::vector<std::vector<float>> frames_;
  std::string source_;
};

}  // namespace

std::shared_ptr<const ReferenceTargets> delta_mush_reference(const Mesh& mesh, const DeltaMushParams& params) {
  return std::make_shared<DeltaMushReference>(mesh, params);
}
std::shared_ptr<const ReferenceTargets> arap_reference(const Mesh& mesh, const ArapParams& params) {
  return std::make_shared<ArapReference>(mesh, params);
}
std::shared_ptr<const ReferenceTargets> file_reference(std::vector<std::vector<float>> frames, std::string source) {
  return std::make_shared<FileReference>(std::move(frames), std::move(source));
}

}  // namespace gatcore::character
