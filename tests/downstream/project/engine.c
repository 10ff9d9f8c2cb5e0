/* The C API as an engine uses it, linked against gatcore::runtime alone (no
 * importer, no trainer): the version, and a load that fails with a clear
 * error instead of crashing. Prints facts the test script checks. */
#include <stdio.h>
#include <string.h>

#include <gatcore/gatcore.h>

int main(void) {
  gatcore_deformer* d = NULL;
  const gatcore_status s = gatcore_deformer_load("/nonexistent/corrective.gcm", GATCORE_DEVICE_CPU, &d);
  printf("engine: version=%s load=%s deformer=%s names_file=%d\n", gatcore_version(), gatcore_status_name(s),
         d == NULL ? "null" : "set", strstr(gatcore_last_error(), "/nonexistent/corrective.gcm") != NULL);
  return s == GATCORE_OK ? 1 : 0;
}
