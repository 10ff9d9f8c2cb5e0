#include "gatcore/models/model_kind.hpp"

#include <string>

#include "gatcore/error.hpp"

namespace gatcore::models {

const std::vector<ModelKind>& all_model_kinds() {
  static const std::vector<ModelKind> kinds{
      ModelKind::densegats,     ModelKind::densegats_noself,     ModelKind::densegats_nodense,
      ModelKind::origat,        ModelKind::neuroskinning,        ModelKind::neuroskinning_nopool,
      ModelKind::skinweights_any, ModelKind::fc,                 ModelKind::pointnet};
  return kinds;
}

const char* model_kind_name(ModelKind k) {
  switch (k) {
    case ModelKind::densegats: return "densegats";
    case ModelKind::densegats_noself: return "densegats-noself";
    case ModelKind::densegats_nodense: return "densegats-nodense";
    case ModelKind::origat: return "origat";
    case ModelKind::neuroskinning: return "neuroskinning";
    case ModelKind::neuroskinning_nopool: return "neuroskinning-nopool";
    case ModelKind::skinweights_any: return "skinweights-any";
    case ModelKind::fc: return "fc";
    case ModelKind::pointnet: return "pointnet";
  }
  return "?";
}

std::optional<ModelKind> parse_model_kind(std::string_view name) {
  for (ModelKind k : all_model_kinds())
    if (name == model_kind_name(k)) return k;
  return std::nullopt;
}

ModelKind model_kind_from_name(std::string_view name) {
  if (auto k = parse_model_kind(name)) return *k;
  std::string known;
  for (ModelKind k : all_model_kinds()) known += std::string(known.empty() ? "" : ", ") + model_kind_name(k);
  throw InvalidArgument("unknown model '" + std::string(name) + "' (known: " + known + ")");
}

bool is_densegats_family(ModelKind k) {
  return k == ModelKind::densegats || k == ModelKind::densegats_noself || k == ModelKind::densegats_nodense;
}
bool predicts_displacement(ModelKind k) { return is_densegats_family(k) || k == ModelKind::origat; }
bool predicts_skin_weights(ModelKind k) { return !predicts_displacement(k); }
bool deployable(ModelKind k) { return predicts_displacement(k); }
bool any_skeleton(ModelKind k) { return k == ModelKind::skinweights_any; }
bool has_neuroskinning_classifier(ModelKind k) {
  return k == ModelKind::neuroskinning || k == ModelKind::neuroskinning_nopool || k == ModelKind::skinweights_any;
}

bool uses_neuroskinning_features(ModelKind k) {
  return k == ModelKind::neuroskinning || k == ModelKind::neuroskinning_nopool || k == ModelKind::fc ||
         k == ModelKind::pointnet;
}

}  // namespace gatcore::models
