/* docs/design.md's "Add an output" recipe followed in a test build (tests/CMakeLists.txt,
 * gearmesh_recipe_tests): force-included into every file of a copy of the core and of the FMU's
 * variable table. Step 1, the row: a test-only output, the normal force summed again. Step 2,
 * its computation in resultants() (core/src/resultants.hpp), here through the build's hook. */
#ifndef GEARMESH_RECIPE_OUTPUT_H
#define GEARMESH_RECIPE_OUTPUT_H

#define GM_OUTPUTS_EXTRA(X, A)                                                                          \
  X(A, recipe_force, Real, SCALAR, RESULTANT, "mesh.recipe_force", "N", "kN", 0, 0, GM_NO_RANGE, CONTACT, \
    "test-only output: the normal slice forces summed again")
#define GM_RESULTANTS_EXTRA(r, F, s) ((r).recipe_force += (F))

#endif
