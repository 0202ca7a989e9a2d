/* The recipe's FMU row (tests/recipe/recipe_output.h): the variable table of the test build
 * lists mesh.recipe_force as a Real output bound to y.recipe_force, in N, with the contact's
 * dependencies. */
#include <string.h>

#include "variables.h"

int recipe_fmu_row_ok(void) {
  for (size_t i = 0; i < GM_FMU_VARIABLE_COUNT; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (strcmp(v->name, "mesh.recipe_force") != 0) continue;
    return v->type == GM_FMU_Real && v->causality == GM_FMU_output && strcmp(v->unit, "N") == 0 &&
           v->offset == offsetof(gm_fmu_values, y.recipe_force) && v->deps == D_CONTACT;
  }
  return 0;
}
