/* A three-joint tube (Hips, Spine, Chest along +y, two influences per
 * vertex) built in plain C, and bent poses of it: the character of the C API
 * example (deform_tube.c) and of its test (tests/c_api_test.c). */
#ifndef GATCORE_EXAMPLE_TUBE_H
#define GATCORE_EXAMPLE_TUBE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

enum { RINGS = 12, SEG = 10, J = 3, K = 2 };
#define NV (RINGS * SEG)
#define NT (2 * (RINGS - 1) * SEG)

static float positions[3 * NV];
static int32_t triangles[3 * NT];
static int32_t joints[K * NV];
static float weights[K * NV];
static const char* names[J] = {"Hips", "Spine", "Chest"};
static const int32_t parents[J] = {-1, 0, 1};
static float rest_local[10 * J];
static float inverse_bind[16 * J];

static void tube_identity(float* m) {
  memset(m, 0, 16 * sizeof(float));
  m[0] = m[5] = m[10] = m[15] = 1.0f;
}

/* A vertical tube, y in [0, 1.2]; joints at y = 0, 0.4, 0.8; two influences per vertex. */
static void build_tube(void) {
  for (int r = 0; r < RINGS; ++r)
    for (int s = 0; s < SEG; ++s) {
      const int v = r * SEG + s;
      const float y = 1.2f * (float)r / (RINGS - 1), a = 6.2831853f * (float)s / SEG;
      positions[3 * v] = 0.15f * cosf(a);
      positions[3 * v + 1] = y;
      positions[3 * v + 2] = 0.15f * sinf(a);
      const float u = y / 0.4f; /* joint coordinate */
      int j0 = (int)floorf(u);
      if (j0 > J - 2) j0 = J - 2;
      float t = u - (float)j0;
      if (t > 1.0f) t = 1.0f;
      joints[K * v] = j0;
      joints[K * v + 1] = j0 + 1;
      weights[K * v] = 1.0f - t;
      weights[K * v + 1] = t;
    }
  int t = 0;
  for (int r = 0; r + 1 < RINGS; ++r)
    for (int s = 0; s < SEG; ++s) {
      const int a = r * SEG + s, b = r * SEG + (s + 1) % SEG, c = a + SEG, d = b + SEG;
      triangles[3 * t] = a, triangles[3 * t + 1] = c, triangles[3 * t + 2] = b, ++t;
      triangles[3 * t] = b, triangles[3 * t + 1] = c, triangles[3 * t + 2] = d, ++t;
    }
  for (int j = 0; j < J; ++j) {
    float* r = rest_local + 10 * j;
    memset(r, 0, 10 * sizeof(float));
    r[1] = j == 0 ? 0.0f : 0.4f;
    r[6] = 1.0f;
    r[7] = r[8] = r[9] = 1.0f;
    tube_identity(inverse_bind + 16 * j);
    inverse_bind[16 * j + 13] = -0.4f * (float)j;
  }
}

/* Joint globals with the spine and chest bent by `angle` about z. */
static void tube_pose(float angle, float* g) {
  const float c = cosf(angle), s = sinf(angle);
  float acc[16], local[16], tmp[16];
  tube_identity(acc);
  for (int j = 0; j < J; ++j) {
    tube_identity(local);
    local[13] = j == 0 ? 0.0f : 0.4f;
    if (j > 0) local[0] = c, local[1] = s, local[4] = -s, local[5] = c;
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) {
        float x = 0;
        for (int k = 0; k < 4; ++k) x += acc[k * 4 + row] * local[col * 4 + k];
        tmp[col * 4 + row] = x;
      }
    memcpy(acc, tmp, sizeof tmp);
    memcpy(g + 16 * j, acc, sizeof acc);
  }
}

#endif /* GATCORE_EXAMPLE_TUBE_H */
