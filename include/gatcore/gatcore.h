/* gatcore C API: the runtime (gatcore/runtime.hpp) for engines and tools
 * that speak C: Unity native plugins, Godot GDExtension, Unreal modules,
 * Python ctypes / cffi.
 *
 *   gatcore_deformer* d = NULL;
 *   if (gatcore_deformer_load("corrective.gcm", GATCORE_DEVICE_CPU, &d) != GATCORE_OK)
 *     fprintf(stderr, "%s\n", gatcore_last_error());
 *   gatcore_deformer_bind(d, &mesh, &skeleton, NULL, 0);            once per character
 *   gatcore_deformer_deform(d, joint_globals, J, positions, NULL, n); every frame
 *   gatcore_deformer_destroy(d);
 *
 * Conventions
 * - Every function returns a gatcore_status; GATCORE_OK is 0. On an error the
 *   calling thread's gatcore_last_error() says what and where (file, argument,
 *   value); no exception ever crosses this boundary. Out-parameters are
 *   written only on success.
 * - Handles are opaque. A deformer holds one bound character and its
 *   workspace: use one per character; different deformers may run on
 *   different threads at once (they share the loaded model read-only when
 *   made with gatcore_deformer_share). One deformer must not be used from two
 *   threads at the same time.
 * - Matrices are 4x4 column-major floats (m[col * 4 + row]), as glTF, Unity's
 *   Matrix4x4 memory layout, Godot's Transform3D basis columns + origin and
 *   Unreal's FMatrix (row-vector convention, same memory order) store them.
 * - Positions are in the skinned mesh's space (bind space); joint_globals are
 *   joint-to-that-space transforms of the current pose. deform() writes the
 *   linear-blend-skinned positions plus the model's correction.
 * - After bind, deform() allocates nothing (CPU device).
 */
#ifndef GATCORE_H
#define GATCORE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define GATCORE_C_API_VERSION 4 /* 2: gatcore_precision, gatcore_deformer_load_precision; 3: gatcore_deformer_absent_bones;
                                   4: skinweights-any checkpoints, gatcore_weight_predictor_set_heat_blend */

typedef enum gatcore_status {
  GATCORE_OK = 0,
  GATCORE_ERROR_INVALID_ARGUMENT = 1, /* a NULL / size / value the call cannot use */
  GATCORE_ERROR_IO = 2,               /* a file missing, unreadable or corrupt */
  GATCORE_ERROR_MODEL = 3,            /* the checkpoint is the wrong kind of model for the call */
  GATCORE_ERROR_STATE = 4,            /* e.g. deform before bind */
  GATCORE_ERROR_DEVICE = 5,           /* the requested device is not available */
  GATCORE_ERROR_OUT_OF_MEMORY = 6,
  GATCORE_ERROR_INTERNAL = 7          /* anything else; the message says what */
} gatcore_status;

typedef enum gatcore_device {
  GATCORE_DEVICE_CPU = 0,
  GATCORE_DEVICE_AUTO = 1,  /* the Vulkan GPU when there is one, else the CPU */
  GATCORE_DEVICE_VULKAN = 2, /* a Vulkan GPU, or GATCORE_ERROR_DEVICE */
  /* Not a device: makes the enum 32 bits wide (as Vulkan's *_MAX_ENUM), so a
   * wrong value a caller passes is a value gatcore can check and refuse
   * (GATCORE_ERROR_ARGUMENT) rather than undefined behaviour in C++. */
  GATCORE_DEVICE_MAX_ENUM = 0x7FFFFFFF
} gatcore_device;

/* Arithmetic of the model's products (CPU device). FP32: `gat deform`'s
 * numbers bitwise. BF16: operands rounded to bfloat16, fp32 accumulation,
 * about twice the products' speed on CPUs with AVX512_BF16 (offsets within
 * ~0.5 % of the fp32 correction); GATCORE_ERROR_DEVICE elsewhere, and on a
 * Vulkan device. */
typedef enum gatcore_precision {
  GATCORE_PRECISION_FP32 = 0,
  GATCORE_PRECISION_BF16 = 1,
  GATCORE_PRECISION_MAX_ENUM = 0x7FFFFFFF /* 32 bits wide, as gatcore_device */
} gatcore_precision;

/* The calling thread's last error message ("" if none). Valid until the
 * thread's next gatcore call. */
const char* gatcore_last_error(void);
/* "GATCORE_OK", "GATCORE_ERROR_IO", ... */
const char* gatcore_status_name(gatcore_status s);
/* Library version, e.g. "0.1.0". */
const char* gatcore_version(void);
/* OpenMP threads the calling thread's gatcore calls use (0: the default). */
gatcore_status gatcore_set_num_threads(int32_t threads);

/* A skeleton: joints ordered parents first. */
typedef struct gatcore_skeleton {
  int32_t num_joints;
  const char* const* names; /* [num_joints] joint names, matched to the model's bones */
  const int32_t* parents;   /* [num_joints] parent index (< j), -1 for a root */
  /* [num_joints * 10] rest pose, relative to the parent: translation x y z,
   * rotation quaternion x y z w, scale x y z */
  const float* rest_local;
  const float* inverse_bind; /* [num_joints * 16] inverse bind matrices */
} gatcore_skeleton;

/* A skinned mesh with a fixed number of influences per vertex (as engines
 * store them). Zero weights are ignored, a joint listed twice for a vertex
 * has its weights summed, and each vertex's weights are renormalised to 1. */
typedef struct gatcore_mesh {
  int64_t num_vertices;
  const float* positions; /* [3 * num_vertices] bind-space positions */
  int64_t num_triangles;
  const int32_t* triangles; /* [3 * num_triangles] vertex indices */
  int32_t influences;       /* k influences per vertex (e.g. 4) */
  const int32_t* joints;    /* [k * num_vertices] joint indices (ignored by weight prediction) */
  const float* weights;     /* [k * num_vertices] (ignored by weight prediction) */
} gatcore_mesh;

/* ---- Corrective deformer (densegats, its ablations, origat checkpoints) ---- */
typedef struct gatcore_deformer gatcore_deformer;

gatcore_status gatcore_deformer_load(const char* checkpoint, gatcore_device device, gatcore_deformer** out);
/* gatcore_deformer_load with a precision (gatcore_deformer_load is FP32). */
gatcore_status gatcore_deformer_load_precision(const char* checkpoint, gatcore_device device,
                                               gatcore_precision precision, gatcore_deformer** out);
/* 1 when this CPU runs GATCORE_PRECISION_BF16 (AVX512_BF16), else 0. */
int32_t gatcore_bf16_supported(void);
/* A new, unbound deformer sharing `src`'s loaded model (another character or thread). */
gatcore_status gatcore_deformer_share(const gatcore_deformer* src, gatcore_deformer** out);
void gatcore_deformer_destroy(gatcore_deformer* d); /* NULL is fine */

/* Binds a character: everything that depends only on the rest pose is
 * computed here. `aliases`: optional "JOINT=BONE" strings mapping a joint name
 * to one of the model's bones (as `gat deform --alias`). */
gatcore_status gatcore_deformer_bind(gatcore_deformer* d, const gatcore_mesh* mesh, const gatcore_skeleton* skeleton,
                                     const char* const* aliases, int32_t num_aliases);
/* One frame: joint_globals [16 * num_joints] -> out_positions
 * [3 * num_vertices] (required), out_normals [3 * num_vertices] (NULL: not
 * wanted). num_joints / num_vertices must be the bound character's. */
gatcore_status gatcore_deformer_deform(gatcore_deformer* d, const float* joint_globals, int32_t num_joints,
                                       float* out_positions, float* out_normals, int64_t num_vertices);
gatcore_status gatcore_deformer_info(const gatcore_deformer* d, int64_t* num_vertices, int32_t* num_joints,
                                     int32_t* mapped_joints, int64_t* parameters);
/* The model's bones the bound character lacks although every training
 * character had them: inputs the model never saw, which can spoil the whole
 * correction (warn the user; bind's aliases can map joints onto them).
 * *count (may be NULL): how many. names (may be NULL): their names joined by
 * commas, NUL-terminated, in `capacity` bytes; a buffer too small is
 * GATCORE_ERROR_INVALID_ARGUMENT naming the size needed. 0 / "" for
 * nearest-joint models and checkpoints that do not record their training
 * bones. */
gatcore_status gatcore_deformer_absent_bones(const gatcore_deformer* d, int32_t* count, char* names, size_t capacity);
/* Milliseconds of the last deform: features, model, total (any may be NULL). */
gatcore_status gatcore_deformer_last_timing(const gatcore_deformer* d, double* features_ms, double* model_ms,
                                            double* total_ms);

/* ---- Skin-weight prediction (neuroskinning, pointnet, fc checkpoints, matched
 * by joint name; skinweights-any checkpoints, any skeleton) ---- */
typedef struct gatcore_weight_predictor gatcore_weight_predictor;

gatcore_status gatcore_weight_predictor_load(const char* checkpoint, gatcore_device device,
                                             gatcore_weight_predictor** out);
void gatcore_weight_predictor_destroy(gatcore_weight_predictor* p);
/* The mesh's own joints / weights are not read. Writes k influences per
 * vertex, strongest first, padded with (joint 0, weight 0):
 * out_joints / out_weights [k * num_vertices]. */
gatcore_status gatcore_weight_predictor_predict(gatcore_weight_predictor* p, const gatcore_mesh* mesh,
                                                const gatcore_skeleton* skeleton, int32_t k, int32_t* out_joints,
                                                float* out_weights);
/* Later predictions mix the model's weights with bone heat's: (1 - share) *
 * model + share * bone heat per vertex, the largest k kept (as gat
 * predict-weights --heat-blend; default: the share calibrated into the
 * checkpoint by gat calibrate, else 0, the model alone). share in [0, 1]. */
gatcore_status gatcore_weight_predictor_set_heat_blend(gatcore_weight_predictor* p, float share);
/* Later predictions drop each vertex's influences below `share` of its total
 * and renormalise, after the heat blend (as gat predict-weights
 * --min-weight; default: the value calibrated into the checkpoint, else 0,
 * none). share in [0, 1). */
gatcore_status gatcore_weight_predictor_set_min_weight(gatcore_weight_predictor* p, float share);

#ifdef __cplusplus
}
#endif

#endif /* GATCORE_H */
