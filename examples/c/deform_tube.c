/* The gatcore C API from plain C: load a corrective checkpoint, bind a
 * character (a three-joint tube built in tube.h; in an engine: the skinned
 * mesh and its skeleton), deform a bending animation frame by frame, print
 * the per-frame time. The tube's joints are Hips / Spine / Chest; when the
 * model knows other bone names, map them with JOINT=BONE aliases:
 *
 *   deform_tube MODEL.gcm [Chest=upperchest ...]
 */
#include <stdio.h>

#include "examples/c/tube.h"
#include "gatcore/gatcore.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: deform_tube MODEL.gcm [JOINT=BONE ...]\n");
    return 2;
  }
  build_tube();
  const gatcore_mesh mesh = {NV, positions, NT, triangles, K, joints, weights};
  const gatcore_skeleton skeleton = {J, names, parents, rest_local, inverse_bind};

  gatcore_deformer* d = NULL;
  if (gatcore_deformer_load(argv[1], GATCORE_DEVICE_AUTO, &d) != GATCORE_OK ||
      gatcore_deformer_bind(d, &mesh, &skeleton, (const char* const*)(argv + 2), argc - 2) != GATCORE_OK) {
    fprintf(stderr, "deform_tube: %s\n", gatcore_last_error());
    gatcore_deformer_destroy(d);
    return 1;
  }
  static float joint_globals[16 * J], out[3 * NV];
  double total = 0, tip = 0;
  const int frames = 60;
  for (int f = 0; f < frames; ++f) {
    tube_pose(0.8f * sinf(6.2831853f * (float)f / (float)frames), joint_globals); /* the engine's animation */
    if (gatcore_deformer_deform(d, joint_globals, J, out, NULL, NV) != GATCORE_OK) {
      fprintf(stderr, "deform_tube: frame %d: %s\n", f, gatcore_last_error());
      gatcore_deformer_destroy(d);
      return 1;
    }
    double ms = 0;
    gatcore_deformer_last_timing(d, NULL, NULL, &ms);
    total += ms;
    tip = out[3 * (NV - 1)];
  }
  printf("deform_tube: %d frames of %d vertices, %.3f ms per frame; last frame's top vertex x = %.4f\n", frames, NV,
         total / frames, tip);
  gatcore_deformer_destroy(d);
  return 0;
}
