/* A valid compliance database for the fuzz targets: the paper's gear set A at level 5. Both of
 * set A's gears are the same 57-tooth gear (gm_default_params), so one database serves both. */
#ifndef GEARMESH_FUZZ_GCDB_H
#define GEARMESH_FUZZ_GCDB_H

#include "gearmesh/gearmesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Set A (gm_default_params) at level 5 with n_coupled coupled teeth and 3 slices; the
 * compliance paths are left NULL. */
void fuzz_set_a_level5(gm_model_params* p, int coupled_teeth);
/* Write set A's gear as a coarse synthetic database (tests/core/fe_synthetic.hpp: n_roll x n_face
 * grid, n_coupled neighbours each side) to path; aborts on failure. */
void fuzz_write_set_a_gcdb(const char* path, int n_roll, int n_face, int n_coupled);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_FUZZ_GCDB_H */
