/* The C API compiled as C (C11): a three-joint tube built here, a corrective
 * and a skin-weight checkpoint written by the fixture test
 * (test_runtime "[.c_api_fixture]", paths in GATCORE_C_API_MODEL /
 * GATCORE_C_API_WEIGHTS): load, bind, deform, share, predict, and every
 * error as a status code with a message naming the problem. The numbers
 * themselves are compared with the C++ runtime in test_runtime. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "examples/c/tube.h"
#include "gatcore/gatcore.h"

static int failures = 0;
#define EXPECT(cond)                                                          \
  do {                                                                        \
    if (!(cond)) {                                                            \
      fprintf(stderr, "%s:%d: FAILED: %s (last error: %s)\n", __FILE__, __LINE__, #cond, gatcore_last_error()); \
      ++failures;                                                             \
    }                                                                         \
  } while (0)

int main(void) {
  const char* model = getenv("GATCORE_C_API_MODEL");
  const char* wmodel = getenv("GATCORE_C_API_WEIGHTS");
  if (!model || !wmodel) {
    fprintf(stderr, "set GATCORE_C_API_MODEL and GATCORE_C_API_WEIGHTS (the ctest fixture does)\n");
    return 1;
  }
  build_tube();
  gatcore_mesh mesh = {NV, positions, NT, triangles, K, joints, weights};
  gatcore_skeleton sk = {J, names, parents, rest_local, inverse_bind};

  /* Errors: codes and messages. */
  gatcore_deformer* d = NULL;
  EXPECT(gatcore_deformer_load("/nonexistent/model.gcm", GATCORE_DEVICE_CPU, &d) == GATCORE_ERROR_IO);
  EXPECT(strstr(gatcore_last_error(), "/nonexistent/model.gcm") != NULL);
  EXPECT(d == NULL);
  EXPECT(gatcore_deformer_load(NULL, GATCORE_DEVICE_CPU, &d) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(gatcore_deformer_load(model, (gatcore_device)42, &d) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(gatcore_deformer_load(wmodel, GATCORE_DEVICE_CPU, &d) == GATCORE_ERROR_MODEL);
  EXPECT(strstr(gatcore_last_error(), "densegats") != NULL);
  EXPECT(strcmp(gatcore_status_name(GATCORE_ERROR_STATE), "GATCORE_ERROR_STATE") == 0);
  /* bf16 where the CPU has AVX512_BF16, else a device error (from C too). */
  {
    gatcore_deformer* b = NULL;
    const gatcore_status st = gatcore_deformer_load_precision(model, GATCORE_DEVICE_CPU, GATCORE_PRECISION_BF16, &b);
    EXPECT(st == (gatcore_bf16_supported() ? GATCORE_OK : GATCORE_ERROR_DEVICE));
    gatcore_deformer_destroy(b);
  }

  EXPECT(gatcore_deformer_load(model, GATCORE_DEVICE_CPU, &d) == GATCORE_OK);
  EXPECT(strcmp(gatcore_last_error(), "") == 0);
  if (!d) return 1;
  float g[16 * J], out[3 * NV], nrm[3 * NV], out2[3 * NV];
  tube_pose(0.5f, g);
  EXPECT(gatcore_deformer_deform(d, g, J, out, NULL, NV) == GATCORE_ERROR_STATE);
  EXPECT(strstr(gatcore_last_error(), "bind") != NULL);

  triangles[7] = 100000; /* out of range */
  EXPECT(gatcore_deformer_bind(d, &mesh, &sk, NULL, 0) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(strstr(gatcore_last_error(), "mesh") != NULL);
  build_tube();
  weights[5] = -1.0f;
  EXPECT(gatcore_deformer_bind(d, &mesh, &sk, NULL, 0) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(strstr(gatcore_last_error(), "vertex 2") != NULL);
  build_tube();
  const char* bad_alias[1] = {"nonsense"};
  EXPECT(gatcore_deformer_bind(d, &mesh, &sk, bad_alias, 1) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(strstr(gatcore_last_error(), "JOINT=BONE") != NULL);

  /* Bind and deform. */
  const char* alias[1] = {"Chest=chest"};
  EXPECT(gatcore_deformer_bind(d, &mesh, &sk, alias, 1) == GATCORE_OK);
  int64_t nv = 0, params = 0;
  int32_t nj = 0, mapped = 0;
  EXPECT(gatcore_deformer_info(d, &nv, &nj, &mapped, &params) == GATCORE_OK);
  EXPECT(nv == NV && nj == J && mapped == J && params > 0);
  int32_t absent = -1;
  char absent_names[64] = "x";
  EXPECT(gatcore_deformer_absent_bones(d, &absent, absent_names, sizeof absent_names) == GATCORE_OK);
  EXPECT(absent == 0 && absent_names[0] == '\0'); /* the fixture records no training bones */
  EXPECT(gatcore_deformer_deform(d, g, J, out, nrm, NV - 1) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(strstr(gatcore_last_error(), "vertices") != NULL);
  EXPECT(gatcore_deformer_deform(d, g, J + 1, out, nrm, NV) == GATCORE_ERROR_INVALID_ARGUMENT);
  g[3] = NAN;
  EXPECT(gatcore_deformer_deform(d, g, J, out, nrm, NV) == GATCORE_ERROR_INVALID_ARGUMENT);
  EXPECT(strstr(gatcore_last_error(), "non-finite") != NULL);
  tube_pose(0.5f, g);
  EXPECT(gatcore_deformer_deform(d, g, J, out, nrm, NV) == GATCORE_OK);
  double moved = 0;
  for (int v = 0; v < NV; ++v) {
    const float* n = nrm + 3 * v;
    EXPECT(fabsf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0f) < 1e-4f);
    for (int c = 0; c < 3; ++c) {
      EXPECT(isfinite(out[3 * v + c]));
      moved += fabs(out[3 * v + c] - positions[3 * v + c]);
    }
  }
  EXPECT(moved > 1.0); /* the bend moved the upper tube */
  double fms = -1, mms = -1, tms = -1;
  EXPECT(gatcore_deformer_last_timing(d, &fms, &mms, &tms) == GATCORE_OK);
  EXPECT(fms >= 0 && mms >= 0 && tms >= fms + mms - 1e-9);

  /* A second deformer sharing the model gives the same numbers. */
  gatcore_deformer* d2 = NULL;
  EXPECT(gatcore_deformer_share(d, &d2) == GATCORE_OK);
  EXPECT(gatcore_deformer_bind(d2, &mesh, &sk, alias, 1) == GATCORE_OK);
  EXPECT(gatcore_deformer_deform(d2, g, J, out2, NULL, NV) == GATCORE_OK);
  EXPECT(memcmp(out, out2, sizeof out) == 0);
  gatcore_deformer_destroy(d2);
  gatcore_deformer_destroy(d);
  gatcore_deformer_destroy(NULL);

  /* Skin weights. */
  gatcore_weight_predictor* p = NULL;
  EXPECT(gatcore_weight_predictor_load(model, GATCORE_DEVICE_CPU, &p) == GATCORE_ERROR_MODEL);
  EXPECT(gatcore_weight_predictor_load(wmodel, GATCORE_DEVICE_CPU, &p) == GATCORE_OK);
  if (p) {
    int32_t pj[2 * NV];
    float pw[2 * NV];
    EXPECT(gatcore_weight_predictor_predict(p, &mesh, &sk, 0, pj, pw) == GATCORE_ERROR_INVALID_ARGUMENT);
    EXPECT(gatcore_weight_predictor_predict(p, &mesh, &sk, 2, pj, pw) == GATCORE_OK);
    for (int v = 0; v < NV; ++v) {
      EXPECT(fabsf(pw[2 * v] + pw[2 * v + 1] - 1.0f) < 1e-5f);
      EXPECT(pw[2 * v] >= pw[2 * v + 1]);
      EXPECT(pj[2 * v] >= 0 && pj[2 * v] < J);
    }
    /* Mixed with bone heat: still k normalised influences; a share outside
     * [0, 1] is refused. */
    EXPECT(gatcore_weight_predictor_set_heat_blend(p, 1.5f) == GATCORE_ERROR_INVALID_ARGUMENT);
    EXPECT(gatcore_weight_predictor_set_heat_blend(NULL, 0.5f) == GATCORE_ERROR_INVALID_ARGUMENT);
    EXPECT(gatcore_weight_predictor_set_heat_blend(p, 0.5f) == GATCORE_OK);
    EXPECT(gatcore_weight_predictor_predict(p, &mesh, &sk, 2, pj, pw) == GATCORE_OK);
    for (int v = 0; v < NV; ++v) {
      EXPECT(fabsf(pw[2 * v] + pw[2 * v + 1] - 1.0f) < 1e-5f);
      EXPECT(pj[2 * v] >= 0 && pj[2 * v] < J);
    }
    /* A min weight: every kept influence at least that share, each vertex
     * still summing to 1; 1 and NULL are refused. */
    EXPECT(gatcore_weight_predictor_set_min_weight(p, 1.0f) == GATCORE_ERROR_INVALID_ARGUMENT);
    EXPECT(gatcore_weight_predictor_set_min_weight(NULL, 0.3f) == GATCORE_ERROR_INVALID_ARGUMENT);
    EXPECT(gatcore_weight_predictor_set_min_weight(p, 0.45f) == GATCORE_OK);
    EXPECT(gatcore_weight_predictor_predict(p, &mesh, &sk, 2, pj, pw) == GATCORE_OK);
    for (int v = 0; v < NV; ++v) {
      EXPECT(fabsf(pw[2 * v] + pw[2 * v + 1] - 1.0f) < 1e-5f);
      EXPECT(pw[2 * v + 1] == 0.0f || pw[2 * v + 1] >= 0.45f - 1e-6f);
    }
    gatcore_weight_predictor_destroy(p);
  }
  if (failures) fprintf(stderr, "%d failure(s)\n", failures);
  else printf("c_api_test: all checks passed\n");
  return failures ? 1 : 0;
}
