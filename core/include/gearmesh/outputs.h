/* The outputs of one evaluation (gm_result): one row each, the one place an output is declared
 * (docs/design.md, "Add an output"). Generated from it: gm_result (gearmesh.h), the core's result
 * over a scalar type (ResultT<T>, core/src/resultants.hpp) and its copy into gm_result, the
 * directional derivative's combination and copy (core/src/derivatives.cpp), and the FMU's output
 * variables with their ranges (modelDescription/variables.h).
 *
 * X(A, member, type, shape, source, name, unit, display unit, lo, hi, bounds, depends, description)
 *   A: the second argument of GM_OUTPUTS, passed through to X;
 *   type: Real (double) or Integer (int);
 *   shape: SCALAR, or GEAR_AXES: an array [2][3], gear i and the axes x, y, z of the housing frame
 *     H, FMU variables gear<i>.<name>x, y, z;
 *   source: RESULTANT, computed by resultants() (core/src/resultants.hpp) over double and over dual
 *     numbers (a Real one's derivative comes with it; an Integer one's is 0); TE, the transmission
 *     error (evaluate.cpp: from the spins, or solved in quasi-static mode); SOLVER, the force
 *     solve's report (derivative 0);
 *   name: the FMU variable (GEAR_AXES: its stem); unit, display unit: as a parameter's;
 *   lo, hi, bounds: the values it takes, as a parameter's range (gearmesh/parameters.h; GM_NO_RANGE
 *     for none), modelDescription.xml's min and max;
 *   depends: what it depends on at a communication point, the FMU's dependency class (docs/fmi.md,
 *     "Feedthrough"): TE, the contact at the TE; CONTACT, also the damping, which acts after the
 *     solve.
 * Units SI (docs/physics.md §0). The rows are gm_result's members in order (its layout). */
#ifndef GEARMESH_OUTPUTS_H
#define GEARMESH_OUTPUTS_H

/* Rows a build adds (the test of docs/design.md's "Add an output" recipe, tests/recipe/). */
#ifndef GM_OUTPUTS_EXTRA
#define GM_OUTPUTS_EXTRA(X, A)
#endif

#define GM_OUTPUTS(X, A)                                                                                           \
  X(A, force, Real, GEAR_AXES, RESULTANT, "f", "N", "kN", 0, 0, GM_NO_RANGE, CONTACT, "contact force on the gear") \
  X(A, moment, Real, GEAR_AXES, RESULTANT, "m", "N.m", "", 0, 0, GM_NO_RANGE, CONTACT,                            \
    "contact moment about the gear centre")                                                                       \
  /* along the line of action (docs/physics.md §0) */                                                             \
  X(A, te, Real, SCALAR, TE, "mesh.te", "m", "um", 0, 0, GM_NO_RANGE, TE,                                         \
    "transmission error along the line of action")                                                                \
  X(A, te_angle, Real, SCALAR, TE, "mesh.te_angle", "rad", "deg", 0, 0, GM_NO_RANGE, TE,                          \
    "transmission error as an angle of gear 2")                                                                   \
  X(A, normal_force, Real, SCALAR, RESULTANT, "mesh.normal_force", "N", "kN", 0, 0, GM_NO_RANGE, CONTACT,         \
    "sum of the normal slice forces")                                                                             \
  X(A, stiffness, Real, SCALAR, RESULTANT, "mesh.stiffness", "N/m", "N/um", 0, 0, GM_NO_RANGE, TE,                \
    "tangent mesh stiffness along the line of action")                                                            \
  X(A, pairs_in_contact, Integer, SCALAR, RESULTANT, "mesh.pairs_in_contact", "", "", 0, 0, GM_NO_RANGE, CONTACT, \
    "loaded tooth pairs")                                                                                         \
  X(A, flank, Integer, SCALAR, RESULTANT, "mesh.flank", "", "", 0, 3, GM_CLOSED, CONTACT,                         \
    "flank in contact: 0 none, 1 flank A, 2 flank B, 3 both")                                                     \
  X(A, friction_power, Real, SCALAR, RESULTANT, "mesh.friction_power", "W", "", 0, 0, GM_NO_RANGE, CONTACT,       \
    "power dissipated by friction")                                                                               \
  X(A, max_line_load, Real, SCALAR, RESULTANT, "mesh.max_line_load", "N/m", "N/mm", 0, 0, GM_NO_RANGE, CONTACT,   \
    "largest slice line load")                                                                                    \
  /* the load sharing ratio's upper branch */                                                                     \
  X(A, max_load_share, Real, SCALAR, RESULTANT, "mesh.max_load_share", "", "", 0, 0, GM_NO_RANGE, CONTACT,        \
    "share of mesh.normal_force carried by the most loaded tooth pair (0 without contact)")                      \
  X(A, solver_iterations, Integer, SCALAR, SOLVER, "solver.iterations", "", "", 0, 0, GM_NO_RANGE, TE,            \
    "iterations of the last force solve (0 = closed form)")                                                       \
  /* the KKT residual on the approach */                                                                          \
  X(A, solver_residual, Real, SCALAR, SOLVER, "solver.residual", "m", "um", 0, 0, GM_NO_RANGE, TE,                \
    "residual of the last force solve")                                                                           \
  /* sum of int F dDelta at the solved forces (docs/physics.md §6) */                                             \
  X(A, elastic_energy, Real, SCALAR, RESULTANT, "mesh.elastic_energy", "J", "", 0, 0, GM_NO_RANGE, TE,            \
    "elastic energy stored in the loaded slices")                                                                 \
  X(A, damping_power, Real, SCALAR, RESULTANT, "mesh.damping_power", "W", "", 0, 0, GM_NO_RANGE, CONTACT,         \
    "power dissipated by the contact damping")                                                                    \
  GM_OUTPUTS_EXTRA(X, A)

/* A row as a member of a C struct (gm_result). */
#define GM_OUTPUT_CTYPE_Real double
#define GM_OUTPUT_CTYPE_Integer int
#define GM_OUTPUT_DIMS_SCALAR
#define GM_OUTPUT_DIMS_GEAR_AXES [2][3]
#define GM_OUTPUT_MEMBER(A, member, type, shape, source, name, unit, dunit, lo, hi, bounds, depends, desc) \
  GM_OUTPUT_CTYPE_##type member GM_OUTPUT_DIMS_##shape;

#endif /* GEARMESH_OUTPUTS_H */
