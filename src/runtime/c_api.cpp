// The C API (gatcore.h) over runtime::Deformer / WeightPredictor: argument
// checks, conversion of the engine-style arrays into character::Mesh /
// Skeleton, and every exception turned into a status code plus the calling
// thread's last-error message.
#include "gatcore/gatcore.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <new>
#include <string>
#include <utility>

#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/runtime.hpp"

struct gatcore_deformer {
  gatcore::runtime::Deformer d;
};
struct gatcore_weight_predictor {
  gatcore::runtime::WeightPredictor p;
};

namespace {

using namespace gatcore;
using namespace gatcore::character;

thread_local std::string t_last_error;

gatcore_status fail(gatcore_status s, std::string msg) {
  t_last_error = std::move(msg);
  return s;
}

// Runs `f`, mapping exceptions to codes: `invalid` is the code for
// InvalidArgument in this call (bad input, or a model of the wrong kind).
template <class F>
gatcore_status guarded(const char* fn, gatcore_status invalid, F&& f) {
  try {
    t_last_error.clear();
    f();
    return GATCORE_OK;
  } catch (const models::CheckpointError& e) {
    return fail(GATCORE_ERROR_IO, std::string(fn) + ": " + e.what());
  } catch (const InvalidArgument& e) {
    return fail(invalid, std::string(fn) + ": " + e.what());
  } catch (const std::bad_alloc&) {
    return fail(GATCORE_ERROR_OUT_OF_MEMORY, std::string(fn) + ": out of memory");
  } catch (const std::exception& e) {
    return fail(GATCORE_ERROR_INTERNAL, std::string(fn) + ": " + e.what());
  } catch (...) {
    return fail(GATCORE_ERROR_INTERNAL, std::string(fn) + ": unknown error");
  }
}

#define GATCORE_C_REQUIRE(cond, ...)                                                          \
  do {                                                                                       \
    if (!(cond)) return fail(GATCORE_ERROR_INVALID_ARGUMENT, gatcore::detail::cat(__VA_ARGS__)); \
  } while (0)

gatcore_status device_of(const char* fn, gatcore_device d, runtime::DeviceChoice& out) {
  switch (d) {
    case GATCORE_DEVICE_CPU: out = runtime::DeviceChoice::cpu; break;
    case GATCORE_DEVICE_AUTO: out = runtime::DeviceChoice::automatic; break;
    case GATCORE_DEVICE_VULKAN: out = runtime::DeviceChoice::vulkan; break;
    default: return fail(GATCORE_ERROR_INVALID_ARGUMENT, std::string(fn) + ": unknown device " + std::to_string(int(d)));
  }
  try {
    runtime::resolve_device(out);
  } catch (const std::exception& e) {
    return fail(GATCORE_ERROR_DEVICE, std::string(fn) + ": " + e.what());
  }
  return GATCORE_OK;
}

// Throws InvalidArgument naming the field.
Skeleton to_skeleton(const gatcore_skeleton& s) {
  GATCORE_CHECK(s.num_joints > 0, "skeleton: num_joints must be positive, got ", s.num_joints);
  GATCORE_CHECK(s.names && s.parents && s.rest_local && s.inverse_bind,
                "skeleton: names, parents, rest_local and inverse_bind are required (one is NULL)");
  Skeleton k;
  const auto J = std::size_t(s.num_joints);
  for (std::size_t j = 0; j < J; ++j) {
    GATCORE_CHECK(s.names[j], "skeleton: names[", j, "] is NULL");
    k.names.emplace_back(s.names[j]);
    k.parents.push_back(s.parents[j]);
    Transform t;
    const float* r = s.rest_local + 10 * j;
    for (std::size_t c = 0; c < 10; ++c)
      GATCORE_CHECK(std::isfinite(r[c]), "skeleton: rest_local of joint ", j, " (", k.names[j], ") is not finite");
    t.translation = {r[0], r[1], r[2]};
    t.rotation = quat_normalize({r[3], r[4], r[5], r[6]});
    t.scale = {r[7], r[8], r[9]};
    k.rest_local.push_back(t);
    Mat4 m;
    std::copy_n(s.inverse_bind + 16 * j, 16, m.begin());
    for (float x : m) GATCORE_CHECK(std::isfinite(x), "skeleton: inverse_bind of joint ", j, " (", k.names[j], ") is not finite");
    k.inverse_bind.push_back(m);
  }
  k.root_parent.assign(J, mat4_identity());
  k.validate("skeleton");
  return k;
}

// Throws InvalidArgument naming the field. `with_weights` false: the mesh's
// joints / weights are not read.
Mesh to_mesh(const gatcore_mesh& m, std::int32_t num_joints, bool with_weights) {
  GATCORE_CHECK(m.num_vertices > 0 && m.num_triangles > 0, "mesh: needs vertices and triangles, got ", m.num_vertices,
                " vertices and ", m.num_triangles, " triangles");
  GATCORE_CHECK(m.positions && m.triangles, "mesh: positions and triangles are required (one is NULL)");
  Mesh out;
  out.positions.assign(m.positions, m.positions + 3 * m.num_vertices);
  out.triangles.assign(m.triangles, m.triangles + 3 * m.num_triangles);
  SkinWeights& w = out.weights;
  w.ptr.assign(1, 0);
  if (!with_weights) {
    for (std::int64_t v = 0; v < m.num_vertices; ++v) {
      w.joint.push_back(0);
      w.weight.push_back(1.0f);
      w.ptr.push_back(v + 1);
    }
    return out;
  }
  GATCORE_CHECK(m.influences > 0, "mesh: influences must be positive, got ", m.influences);
  GATCORE_CHECK(m.joints && m.weights, "mesh: joints and weights are required (one is NULL)");
  const std::int64_t k = m.influences;
  std::vector<std::pair<std::int32_t, float>> row;
  for (std::int64_t v = 0; v < m.num_vertices; ++v) {
    row.clear();
    for (std::int64_t i = 0; i < k; ++i) {
      const std::int32_t j = m.joints[v * k + i];
      const float x = m.weights[v * k + i];
      GATCORE_CHECK(std::isfinite(x) && x >= 0.0f, "mesh: weight ", i, " of vertex ", v, " is ", x,
                    " (weights must be finite and >= 0)");
      if (x == 0.0f) continue;
      GATCORE_CHECK(j >= 0 && j < num_joints, "mesh: vertex ", v, " is weighted to joint ", j, " of ", num_joints);
      row.emplace_back(j, x);
    }
    GATCORE_CHECK(!row.empty(), "mesh: vertex ", v, " has no non-zero weight");
    std::sort(row.begin(), row.end());
    double sum = 0;
    for (const auto& e : row) sum += e.second;
    // Weights that already sum to 1 are kept as given (bit for bit: the same
    // skinning as a C++ caller passing them).
    const bool keep = std::abs(sum - 1.0) <= 1e-6;
    for (std::size_t i = 0; i < row.size(); ++i) {
      const float x = keep ? row[i].second : float(row[i].second / sum);
      if (i > 0 && row[i].first == row[i - 1].first) {
        w.weight.back() += x;
        continue;
      }
      w.joint.push_back(row[i].first);
      w.weight.push_back(x);
    }
    w.ptr.push_back(std::int64_t(w.joint.size()));
  }
  return out;
}

}  // namespace

extern "C" {

const char* gatcore_last_error(void) { return t_last_error.c_str(); }

const char* gatcore_status_name(gatcore_status s) {
  switch (s) {
    case GATCORE_OK: return "GATCORE_OK";
    case GATCORE_ERROR_INVALID_ARGUMENT: return "GATCORE_ERROR_INVALID_ARGUMENT";
    case GATCORE_ERROR_IO: return "GATCORE_ERROR_IO";
    case GATCORE_ERROR_MODEL: return "GATCORE_ERROR_MODEL";
    case GATCORE_ERROR_STATE: return "GATCORE_ERROR_STATE";
    case GATCORE_ERROR_DEVICE: return "GATCORE_ERROR_DEVICE";
    case GATCORE_ERROR_OUT_OF_MEMORY: return "GATCORE_ERROR_OUT_OF_MEMORY";
    case GATCORE_ERROR_INTERNAL: return "GATCORE_ERROR_INTERNAL";
  }
  return "unknown gatcore_status";
}

const char* gatcore_version(void) { return GATCORE_VERSION_STRING; }

gatcore_status gatcore_set_num_threads(int32_t threads) {
  GATCORE_C_REQUIRE(threads >= 0, "gatcore_set_num_threads: threads must be >= 0, got ", threads);
  t_last_error.clear();
  omp_set_num_threads(threads > 0 ? threads : omp_get_num_procs());
  return GATCORE_OK;
}

gatcore_status gatcore_deformer_load(const char* checkpoint, gatcore_device device, gatcore_deformer** out) {
  GATCORE_C_REQUIRE(checkpoint && out, "gatcore_deformer_load: checkpoint and out must not be NULL");
  runtime::DeviceChoice dc{};
  if (gatcore_status s = device_of("gatcore_deformer_load", device, dc); s != GATCORE_OK) return s;
  return guarded("gatcore_deformer_load", GATCORE_ERROR_MODEL,
                 [&] { *out = new gatcore_deformer{runtime::Deformer::load(checkpoint, dc)}; });
}

gatcore_status gatcore_deformer_load_precision(const char* checkpoint, gatcore_device device,
                                               gatcore_precision precision, gatcore_deformer** out) {
  static const char* fn = "gatcore_deformer_load_precision";
  GATCORE_C_REQUIRE(checkpoint && out, fn, ": checkpoint and out must not be NULL");
  GATCORE_C_REQUIRE(precision == GATCORE_PRECISION_FP32 || precision == GATCORE_PRECISION_BF16, fn,
                    ": unknown precision ", int(precision));
  runtime::DeviceChoice dc{};
  if (gatcore_status s = device_of(fn, device, dc); s != GATCORE_OK) return s;
  const Precision p = precision == GATCORE_PRECISION_BF16 ? Precision::bf16 : Precision::fp32;
  if (p == Precision::bf16) {
    // Device problems are the device's code, not the model's.
    if (!bf16_supported())
      return fail(GATCORE_ERROR_DEVICE, std::string(fn) + ": GATCORE_PRECISION_BF16 needs a CPU with AVX512_BF16; "
                                                          "this one has none (use GATCORE_PRECISION_FP32)");
    if (runtime::resolve_device(dc) != Device::cpu)
      return fail(GATCORE_ERROR_DEVICE, std::string(fn) + ": GATCORE_PRECISION_BF16 runs on the CPU device only");
  }
  return guarded(fn, GATCORE_ERROR_MODEL, [&] { *out = new gatcore_deformer{runtime::Deformer::load(checkpoint, dc, p)}; });
}

int32_t gatcore_bf16_supported(void) { return bf16_supported() ? 1 : 0; }

gatcore_status gatcore_deformer_share(const gatcore_deformer* src, gatcore_deformer** out) {
  GATCORE_C_REQUIRE(src && out, "gatcore_deformer_share: src and out must not be NULL");
  return guarded("gatcore_deformer_share", GATCORE_ERROR_INVALID_ARGUMENT,
                 [&] { *out = new gatcore_deformer{src->d.share()}; });
}

void gatcore_deformer_destroy(gatcore_deformer* d) { delete d; }

gatcore_status gatcore_deformer_bind(gatcore_deformer* d, const gatcore_mesh* mesh, const gatcore_skeleton* skeleton,
                                     const char* const* aliases, int32_t num_aliases) {
  GATCORE_C_REQUIRE(d && mesh && skeleton, "gatcore_deformer_bind: deformer, mesh and skeleton must not be NULL");
  GATCORE_C_REQUIRE(num_aliases >= 0 && (num_aliases == 0 || aliases), "gatcore_deformer_bind: ", num_aliases,
                    " aliases but the array is NULL");
  return guarded("gatcore_deformer_bind", GATCORE_ERROR_INVALID_ARGUMENT, [&] {
    runtime::BindOptions opt;
    for (std::int32_t i = 0; i < num_aliases; ++i) {
      GATCORE_CHECK(aliases[i], "aliases[", i, "] is NULL");
      const std::string spec = aliases[i];
      const auto eq = spec.find('=');
      GATCORE_CHECK(eq != std::string::npos && eq > 0 && eq + 1 < spec.size(), "aliases[", i,
                    "]: expected JOINT=BONE, got '", spec, "'");
      opt.aliases.pairs.emplace_back(normalise_bone_name(spec.substr(0, eq)), normalise_bone_name(spec.substr(eq + 1)));
    }
    const Skeleton sk = to_skeleton(*skeleton);
    d->d.bind(to_mesh(*mesh, sk.num_joints(), true), sk, opt);
  });
}

gatcore_status gatcore_deformer_deform(gatcore_deformer* d, const float* joint_globals, int32_t num_joints,
                                       float* out_positions, float* out_normals, int64_t num_vertices) {
  GATCORE_C_REQUIRE(d && joint_globals && out_positions,
                    "gatcore_deformer_deform: deformer, joint_globals and out_positions must not be NULL");
  if (!d->d.bound()) return fail(GATCORE_ERROR_STATE, "gatcore_deformer_deform: bind a character first");
  GATCORE_C_REQUIRE(num_joints == d->d.num_joints(), "gatcore_deformer_deform: ", num_joints,
                    " joints given, the bound skeleton has ", d->d.num_joints());
  GATCORE_C_REQUIRE(num_vertices == d->d.num_vertices(), "gatcore_deformer_deform: ", num_vertices,
                    " vertices given, the bound mesh has ", d->d.num_vertices());
  const auto n3 = std::size_t(3 * num_vertices);
  return guarded("gatcore_deformer_deform", GATCORE_ERROR_INVALID_ARGUMENT, [&] {
    d->d.deform({joint_globals, std::size_t(16) * std::size_t(num_joints)}, {out_positions, n3},
                out_normals ? std::span<float>(out_normals, n3) : std::span<float>{});
  });
}

gatcore_status gatcore_deformer_info(const gatcore_deformer* d, int64_t* num_vertices, int32_t* num_joints,
                                     int32_t* mapped_joints, int64_t* parameters) {
  GATCORE_C_REQUIRE(d, "gatcore_deformer_info: deformer must not be NULL");
  t_last_error.clear();
  if (num_vertices) *num_vertices = d->d.num_vertices();
  if (num_joints) *num_joints = d->d.num_joints();
  if (mapped_joints) *mapped_joints = d->d.mapped_joints();
  if (parameters) *parameters = d->d.parameter_count();
  return GATCORE_OK;
}

gatcore_status gatcore_deformer_absent_bones(const gatcore_deformer* d, int32_t* count, char* names, size_t capacity) {
  GATCORE_C_REQUIRE(d, "gatcore_deformer_absent_bones: deformer must not be NULL");
  GATCORE_C_REQUIRE(d->d.bound(), "gatcore_deformer_absent_bones: bind a character first");
  const std::vector<std::string> absent = d->d.unseen_absent_bones();
  std::string joined;
  for (const auto& b : absent) {
    if (!joined.empty()) joined += ',';
    joined += b;
  }
  GATCORE_C_REQUIRE(!names || capacity > joined.size(), "gatcore_deformer_absent_bones: the names need ",
                    joined.size() + 1, " bytes, capacity is ", capacity);
  t_last_error.clear();
  if (count) *count = int32_t(absent.size());
  if (names) std::memcpy(names, joined.c_str(), joined.size() + 1);
  return GATCORE_OK;
}

gatcore_status gatcore_deformer_last_timing(const gatcore_deformer* d, double* features_ms, double* model_ms,
                                            double* total_ms) {
  GATCORE_C_REQUIRE(d, "gatcore_deformer_last_timing: deformer must not be NULL");
  t_last_error.clear();
  const runtime::FrameTiming t = d->d.last_timing();
  if (features_ms) *features_ms = t.features_ms;
  if (model_ms) *model_ms = t.model_ms;
  if (total_ms) *total_ms = t.total_ms;
  return GATCORE_OK;
}

gatcore_status gatcore_weight_predictor_load(const char* checkpoint, gatcore_device device,
                                             gatcore_weight_predictor** out) {
  GATCORE_C_REQUIRE(checkpoint && out, "gatcore_weight_predictor_load: checkpoint and out must not be NULL");
  runtime::DeviceChoice dc{};
  if (gatcore_status s = device_of("gatcore_weight_predictor_load", device, dc); s != GATCORE_OK) return s;
  return guarded("gatcore_weight_predictor_load", GATCORE_ERROR_MODEL,
                 [&] { *out = new gatcore_weight_predictor{runtime::WeightPredictor::load(checkpoint, dc)}; });
}

void gatcore_weight_predictor_destroy(gatcore_weight_predictor* p) { delete p; }

gatcore_status gatcore_weight_predictor_predict(gatcore_weight_predictor* p, const gatcore_mesh* mesh,
                                                const gatcore_skeleton* skeleton, int32_t k, int32_t* out_joints,
                                                float* out_weights) {
  GATCORE_C_REQUIRE(p && mesh && skeleton && out_joints && out_weights,
                    "gatcore_weight_predictor_predict: no argument may be NULL");
  GATCORE_C_REQUIRE(k >= 1, "gatcore_weight_predictor_predict: k must be >= 1, got ", k);
  return guarded("gatcore_weight_predictor_predict", GATCORE_ERROR_INVALID_ARGUMENT, [&] {
    const Skeleton sk = to_skeleton(*skeleton);
    const Mesh m = to_mesh(*mesh, sk.num_joints(), false);
    const SkinWeights w = p->p.predict(m, sk, k);
    std::vector<std::pair<float, std::int32_t>> row;
    for (std::int64_t v = 0; v < m.num_vertices(); ++v) {
      row.clear();
      for (std::int64_t e = w.ptr[std::size_t(v)]; e < w.ptr[std::size_t(v) + 1]; ++e)
        row.emplace_back(w.weight[std::size_t(e)], w.joint[std::size_t(e)]);
      std::sort(row.begin(), row.end(), [](const auto& a, const auto& b) {
        return a.first > b.first || (a.first == b.first && a.second < b.second);
      });
      for (std::int32_t i = 0; i < k; ++i) {
        const bool has = std::size_t(i) < row.size();
        out_joints[v * k + i] = has ? row[std::size_t(i)].second : 0;
        out_weights[v * k + i] = has ? row[std::size_t(i)].first : 0.0f;
      }
    }
  });
}

gatcore_status gatcore_weight_predictor_set_heat_blend(gatcore_weight_predictor* p, float share) {
  GATCORE_C_REQUIRE(p, "gatcore_weight_predictor_set_heat_blend: p must not be NULL");
  return guarded("gatcore_weight_predictor_set_heat_blend", GATCORE_ERROR_INVALID_ARGUMENT,
                 [&] { p->p.set_heat_blend(share); });
}

gatcore_status gatcore_weight_predictor_set_min_weight(gatcore_weight_predictor* p, float share) {
  GATCORE_C_REQUIRE(p, "gatcore_weight_predictor_set_min_weight: p must not be NULL");
  return guarded("gatcore_weight_predictor_set_min_weight", GATCORE_ERROR_INVALID_ARGUMENT,
                 [&] { p->p.set_min_weight(share); });
}

}  // extern "C"
