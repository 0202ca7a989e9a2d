/* The parameters of GearMesh: one row each, the one place a parameter's name, field, type, unit,
 * range and use are written (docs/design.md, "Add a parameter"). Generated from this table: the
 * core's range checks (core/src/parameters.cpp, one loop), the name-based lookup and setter below
 * (compliance_tool's --param), the FMU's parameter variables (modelDescription/variables.h) and
 * its resource files (fmu_src/core_params.c), and what the Python tooling reads back from
 * modelDescription.xml (min and max, the levels and modes that read a parameter, the gear body).
 *
 * A range is static: its bounds are constants. Bounds that depend on other parameters (e.g.
 * pair.rack_dedendum > pair.rack_addendum) are further checks after the static one
 * (core/src/params.cpp); the static range is then the envelope of every admissible case.
 * FMI 2.0 has no open bounds: for a bound marked open, min/max state its value and the
 * variable's description says "exclusive" (modelDescription.xml also carries the flag in the
 * model's vendor annotation, for tools).
 */
#ifndef GEARMESH_PARAMETERS_H
#define GEARMESH_PARAMETERS_H

#include <math.h>
#include <stddef.h>

#include "gearmesh/gearmesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Bounds of a row's range; NONE: no static range (Booleans: 0 or 1; Strings). */
enum { GM_CLOSED = 0,
       GM_LO_OPEN = 1,
       GM_HI_OPEN = 2,
       GM_OPEN = 3,
       GM_NO_RANGE = 4 };

/* The stiffness levels that read a parameter (gm_stiffness_level), as a bit set. */
#define GM_LEVEL(l) (1u << (l))
#define GM_ALL_LEVELS ((1u << GM_STIFFNESS_LEVELS) - 1u)

/* The modes that read it: prescribed spins, quasi-static (model_params.quasi_static), large-step
 * (gm_dynamics_*). */
enum { GM_MODE_PRESCRIBED = 1,
       GM_MODE_QUASI_STATIC = 2,
       GM_MODE_LARGE_STEP = 4,
       GM_ALL_MODES = 7 };

/* What a parameter is part of (a calculated row: what it is calculated from), as a bit set: the
 * pair geometry, the other model settings (material, micro-geometry, stiffness model, friction,
 * solver, the mode switches), the large-step dynamics. The FMU's dependency classes
 * (modelDescription/variables.h: D_GEO, D_SET, D_DYN) are these bits. */
enum { GM_GROUP_GEOMETRY = 1,
       GM_GROUP_SETTING = 2,
       GM_GROUP_DYNAMICS = 4 };

/* Flags: BODY, compliance_tool reads it (the gear body and its validation); FILE, a String naming
 * a file (read at gm_model_create; the FMU's resources/); FLANK, a flank modification bound to
 * flank A's field (gm_model_create checks flank B's alike; the FMU gives flank B flank A's);
 * STRUCTURAL, it sets the dimensions of the FMU's arrays (FMI 3.0 structural parameter). */
enum { GM_PARAM_BODY = 1,
       GM_PARAM_FILE = 2,
       GM_PARAM_FLANK = 4,
       GM_PARAM_STRUCTURAL = 8 };

/* Where a row's value lives: MODEL, in gm_model_params; DYNAMICS, in gm_dynamics_params; HOST, a
 * setting of the program that runs the core (the FMU: the mode switch and the large-step mesh
 * damping). Kind: parameter, or calculated (a value the host computes from the parameters). */

#define GM_DEG (3.14159265358979323846 / 180.0)
#define GM_MAX_MODULE 0.1 /* pair.normal_module, m */
#define GM_MAX_AMOUNT 1e-3 /* micro-geometry amounts and slopes, m */
#define GM_MAX_SLICES 200  /* model.slices */

/* X(A, name, kind, type, where, field, unit, display unit, lo, hi, bounds, levels, modes, group,
 *   flags, description), A: the second argument of GM_PARAMETERS, passed through to X (a user
 *   that makes rows of another table passes that table's row macro); per gear (i = 1, 2; field
 *   index n = i - 1) through the GM_PARAMETERS_GEAR* blocks. Units and display units:
 *   modelDescription/variables.h's GM_FMU_UNITS. */
#define GM_PARAMETERS_FLANK(X, A, i, n, field, type, unit, dunit, lo, hi, desc)                                      \
  X(A, "gear" #i "." #field, parameter, type, MODEL, gear[n].flank[0].field, unit, dunit, lo, hi,                    \
    GM_PARAM_BOUNDS_##type, GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_FLANK,                        \
    desc "; applied to flank A and flank B")
#define GM_PARAM_BOUNDS_Real GM_CLOSED
#define GM_PARAM_BOUNDS_Boolean GM_NO_RANGE

#define GM_PARAMETERS_GEAR(X, A, i, n)                                                                                \
  X(A, "gear" #i ".teeth", parameter, Integer, MODEL, gear[n].teeth, "", "", 5, 2000, GM_CLOSED, GM_ALL_LEVELS,     \
    GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                               \
    "number of teeth z (magnitude; an internal ring is flagged by pair.internal)")                                \
  X(A, "gear" #i ".profile_shift", parameter, Real, MODEL, gear[n].profile_shift, "", "", -1.5, 3.0, GM_CLOSED,      \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "profile shift coefficient x")                  \
  X(A, "gear" #i ".face_width", parameter, Real, MODEL, gear[n].face_width, "m", "mm", 0, 2.0, GM_LO_OPEN,           \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "face width b")                                 \
  X(A, "gear" #i ".tip_diameter", parameter, Real, MODEL, gear[n].tip_diameter, "m", "mm", 0, 40.0, GM_CLOSED,       \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                \
    "tip diameter d_a (ring: inner diameter); 0 = from the basic rack")                                           \
  X(A, "gear" #i ".thickness_allowance", parameter, Real, MODEL, gear[n].thickness_allowance, "m", "um",             \
    -0.5 * GM_MAX_MODULE, 0.0, GM_CLOSED, GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,          \
    "normal tooth thickness allowance E_sn (>= -0.5 pair.normal_module)")                                        \
  X(A, "gear" #i ".axial_offset", parameter, Real, MODEL, gear[n].axial_offset, "m", "mm", -2.0, 2.0, GM_CLOSED,     \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                \
    "mid-face position along the gear axis from the gear centre")                                                 \
  X(A, "gear" #i ".youngs_modulus", parameter, Real, MODEL, gear[n].youngs_modulus, "Pa", "GPa", 1e8, 1e13,          \
    GM_CLOSED, GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_BODY, "Young's modulus E")                  \
  X(A, "gear" #i ".poisson_ratio", parameter, Real, MODEL, gear[n].poisson_ratio, "", "", 0.0, 0.5, GM_HI_OPEN,      \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_BODY, "Poisson's ratio nu")                            \
  GM_PARAMETERS_FLANK(X, A, i, n, profile_crowning, Real, "m", "um", 0, GM_MAX_AMOUNT,                               \
                      "profile crowning C_alpha: parabola over the active profile, C at both ends")               \
  GM_PARAMETERS_FLANK(X, A, i, n, tip_relief, Real, "m", "um", 0, GM_MAX_AMOUNT, "tip relief C_a at the tip")        \
  GM_PARAMETERS_FLANK(X, A, i, n, tip_relief_length, Real, "m", "mm", 0, HUGE_VAL,                                   \
                      "roll length L_a of the tip relief from the tip (while C_a != 0: > 0 and <= the active "     \
                      "profile)")                                                                                 \
  GM_PARAMETERS_FLANK(X, A, i, n, tip_relief_parabolic, Boolean, "", "", 0, 1,                                       \
                      "tip relief shape: false linear, true parabolic")                                           \
  GM_PARAMETERS_FLANK(X, A, i, n, root_relief, Real, "m", "um", 0, GM_MAX_AMOUNT,                                    \
                      "root relief C_f at the start of active profile")                                           \
  GM_PARAMETERS_FLANK(X, A, i, n, root_relief_length, Real, "m", "mm", 0, HUGE_VAL,                                  \
                      "roll length L_f of the root relief from the start of active profile (while C_f != 0: > 0 " \
                      "and <= the active profile less L_a)")                                                      \
  GM_PARAMETERS_FLANK(X, A, i, n, root_relief_parabolic, Boolean, "", "", 0, 1,                                      \
                      "root relief shape: false linear, true parabolic")                                          \
  GM_PARAMETERS_FLANK(X, A, i, n, profile_slope, Real, "m", "um", -GM_MAX_AMOUNT, GM_MAX_AMOUNT,                     \
                      "profile slope f_Halpha: gap at the tip minus gap at the start")                            \
  GM_PARAMETERS_FLANK(X, A, i, n, lead_crowning, Real, "m", "um", 0, GM_MAX_AMOUNT,                                  \
                      "lead crowning C_beta: parabola, C at both face ends")                                      \
  GM_PARAMETERS_FLANK(X, A, i, n, helix_slope, Real, "m", "um", -GM_MAX_AMOUNT, GM_MAX_AMOUNT,                       \
                      "helix slope f_Hbeta: gap at face end y = +b/2 minus gap at y = -b/2")                      \
  GM_PARAMETERS_FLANK(X, A, i, n, end_relief, Real, "m", "um", 0, GM_MAX_AMOUNT,                                     \
                      "end relief C_I at both face ends, linear")                                                 \
  GM_PARAMETERS_FLANK(X, A, i, n, end_relief_length, Real, "m", "mm", 0, HUGE_VAL,                                   \
                      "length of the end relief from each face end (while C_I != 0: > 0 and <= b/2)")             \
  X(A, "gear" #i ".deviations", parameter, String, MODEL, gear[n].deviations, "", "", 0, 0, GM_NO_RANGE,             \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_FILE,                                                 \
    "file name of a flank deviation file (measured grids, pitch; per tooth and flank) inside the FMU's "          \
    "resources/ folder, \"\" = none; relative, without \"..\" or backslashes")                                    \
  X(A, "gear" #i ".compliance", parameter, String, MODEL, compliance[n], "", "", 0, 0, GM_NO_RANGE, GM_LEVEL(5),     \
    GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_FILE,                                                                \
    "level 5 (required there, \"\" at other levels): file name of this gear's compliance database (.gcdb, "     \
    "made by compliance_tool for this gear) inside the FMU's resources/ folder; relative, without \"..\" or "   \
    "backslashes")

/* The large-step dynamics of gear i (core/src/dynamics.hpp). */
#define GM_PARAMETERS_GEAR_DYNAMICS(X, A, i, n)                                                                       \
  X(A, "gear" #i ".inertia", parameter, Real, DYNAMICS, inertia[n], "kg.m2", "", 1e-9, 1e6, GM_CLOSED, GM_ALL_LEVELS,  \
    GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0, "large-step mode: moment of inertia about the spin axis")            \
  X(A, "gear" #i ".shaft_stiffness", parameter, Real, DYNAMICS, shaft_stiffness[n], "N.m/rad", "", 0, 1e12,          \
    GM_CLOSED, GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0,                                           \
    "large-step mode: torsional stiffness of the shaft from the gear to its far end (0 = no shaft)")              \
  X(A, "gear" #i ".shaft_damping", parameter, Real, DYNAMICS, shaft_damping[n], "N.m.s/rad", "", 0, 1e9, GM_CLOSED,  \
    GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0, "large-step mode: torsional damping of that shaft")

#define GM_PARAMETERS(X, A)                                                                                           \
  X(A, "pair.center_distance", parameter, Real, MODEL, pair.center_distance, "m", "mm", 0, 20, GM_LO_OPEN,           \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                 \
    "operating centre distance a (positive also for internal pairs)")                                             \
  X(A, "pair.normal_module", parameter, Real, MODEL, pair.normal_module, "m", "mm", 1e-4, GM_MAX_MODULE, GM_CLOSED,  \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "normal module m_n")                            \
  X(A, "pair.pressure_angle", parameter, Real, MODEL, pair.pressure_angle, "rad", "deg", 10 * GM_DEG, 35 * GM_DEG,   \
    GM_CLOSED, GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "normal pressure angle alpha_n")     \
  X(A, "pair.helix_angle", parameter, Real, MODEL, pair.helix_angle, "rad", "deg", -45 * GM_DEG, 45 * GM_DEG,        \
    GM_OPEN, GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                       \
    "helix angle beta of gear 1 (sign = hand, + right)")                                                          \
  X(A, "pair.internal", parameter, Boolean, MODEL, pair.internal, "", "", 0, 1, GM_NO_RANGE, GM_ALL_LEVELS,          \
    GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "gear 2 is an internal ring")                                  \
  X(A, "pair.rack_addendum", parameter, Real, MODEL, pair.rack_addendum, "", "", 0.5, 2.0, GM_CLOSED, GM_ALL_LEVELS, \
    GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY, "basic rack addendum h_aP*, in modules")                       \
  X(A, "pair.rack_dedendum", parameter, Real, MODEL, pair.rack_dedendum, "", "", 0.5, 3.0, GM_LO_OPEN, GM_ALL_LEVELS, \
    GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                               \
    "basic rack dedendum h_fP*, in modules (> pair.rack_addendum)")                                               \
  X(A, "pair.rack_tip_radius", parameter, Real, MODEL, pair.rack_tip_radius, "", "", 0.0, 1.0, GM_CLOSED,            \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_GEOMETRY, GM_PARAM_BODY,                                                \
    "basic rack tip radius rho_fP*, in modules (<= 1.01 times the full round (h_fP* - h_aP*)/(1 - sin alpha_n))") \
  GM_PARAMETERS_GEAR(X, A, 1, 0)                                                                                     \
  GM_PARAMETERS_GEAR(X, A, 2, 1)                                                                                     \
  X(A, "model.stiffness", parameter, Integer, MODEL, stiffness_level, "", "", 0, GM_STIFFNESS_LEVELS - 1, GM_CLOSED, \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, 0,                                                             \
    "stiffness level: 0 user constant, 1 user table, 2 ISO 6336-1, 3 contact-line length, 4 analytical, 5 FE")    \
  X(A, "model.user_stiffness", parameter, Real, MODEL, user_stiffness, "N/m2", "N/(mm.um)", 0, 1e14, GM_LO_OPEN,     \
    GM_LEVEL(0), GM_ALL_MODES, GM_GROUP_SETTING, 0,                                                               \
    "level 0: stiffness of one tooth pair per unit face width on the transverse line of action (as ISO "          \
    "6336-1's c')")                                                                                               \
  X(A, "model.stiffness_table", parameter, String, MODEL, stiffness_table, "", "", 0, 0, GM_NO_RANGE, GM_LEVEL(1),   \
    GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_FILE,                                                                \
    "level 1 (required there, \"\" at other levels): file name of a stiffness table (pair stiffness per unit "   \
    "face width over gear 1's roll angle) inside the FMU's resources/ folder; relative, without \"..\" or "      \
    "backslashes")                                                                                                \
  X(A, "model.te_table", parameter, String, MODEL, te_table, "", "", 0, 0, GM_NO_RANGE, GM_ALL_LEVELS, GM_ALL_MODES, \
    GM_GROUP_SETTING, GM_PARAM_FILE,                                                                              \
    "any level: file name of a TE excitation table (over gear 1's angle within one pitch; opens both flanks by "  \
    "it) inside the FMU's resources/ folder, \"\" = none; relative, without \"..\" or backslashes")              \
  X(A, "model.slices", parameter, Integer, MODEL, slices, "", "", 1, GM_MAX_SLICES, GM_CLOSED, GM_ALL_LEVELS,    \
    GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_STRUCTURAL,                                                          \
    "slices across the axial overlap")                                                       \
  X(A, "model.coupled_teeth", parameter, Integer, MODEL, coupled_teeth, "", "", 0, 10, GM_CLOSED,                    \
    GM_LEVEL(4) | GM_LEVEL(5), GM_ALL_MODES, GM_GROUP_SETTING, GM_PARAM_BODY,                                     \
    "levels 4 and 5: neighbouring teeth coupled on each side (level 4: at most 3, 0 = uncoupled)")                \
  X(A, "model.friction_coefficient", parameter, Real, MODEL, friction_coefficient, "", "", 0, 2.0, GM_CLOSED,        \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, 0, "friction coefficient mu")                                   \
  X(A, "model.friction_velocity", parameter, Real, MODEL, friction_velocity, "m/s", "mm/s", 0, 10.0, GM_LO_OPEN,     \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, 0, "friction regularization velocity v0")                       \
  X(A, "model.damping", parameter, Real, MODEL, damping, "N.s/m2", "", 0, 1e9, GM_CLOSED, GM_ALL_LEVELS,             \
    GM_ALL_MODES, GM_GROUP_SETTING, 0, "normal damping per unit face width")                                       \
  X(A, "solver.tolerance", parameter, Real, MODEL, solver_tolerance, "m", "um", 0, 1e-3, GM_LO_OPEN, GM_ALL_LEVELS,  \
    GM_ALL_MODES, GM_GROUP_SETTING, 0, "tolerance of the force solve on the approach")                             \
  X(A, "solver.max_iterations", parameter, Integer, MODEL, solver_max_iterations, "", "", 1, 10000, GM_CLOSED,       \
    GM_ALL_LEVELS, GM_ALL_MODES, GM_GROUP_SETTING, 0, "iteration cap of the force solve")                          \
  X(A, "solver.face_shapes", parameter, Integer, MODEL, solver_face_shapes, "", "", 0, 8, GM_CLOSED, GM_LEVEL(5),     \
    GM_ALL_MODES, GM_GROUP_SETTING, 0,                                                                            \
    "level 5, spur pairs: load shapes across the face per loaded tooth pair as the unknowns of the coupled "    \
    "solve (up to 3: responses to a uniform approach; from the 4th: to a tilt); the solve over every slice "    \
    "where the approaches across a face vary otherwise, a slice would unload, and on helical pairs; "        \
    "0 = every slice an unknown")                                                        \
  X(A, "model.rated_line_load", parameter, Real, MODEL, rated_line_load, "N/m", "N/mm", 0, 1e8, GM_CLOSED,           \
    GM_LEVEL(2), GM_ALL_MODES, GM_GROUP_SETTING, 0,                                                               \
    "level 2: F_t K_A/b for ISO 6336-1's load correction of c' (0 = none)")                                       \
  X(A, "model.quasi_static", parameter, Boolean, MODEL, quasi_static, "", "", 0, 1, GM_NO_RANGE, GM_ALL_LEVELS,      \
    GM_ALL_MODES, GM_GROUP_SETTING, 0, "solve gear 2's spin for mesh.load_torque (gear2.phi is then ignored)")     \
  X(A, "model.dynamics", parameter, Integer, HOST, dynamics, "", "", 0, 1, GM_CLOSED, GM_ALL_LEVELS, GM_ALL_MODES,   \
    GM_GROUP_SETTING, 0,                                                                                          \
    "0 prescribed motion (spins are inputs); 1 large-step: both spins integrated inside fmi2DoStep from "         \
    "gear<i>.torque and the shafts (gear<i>.phi/.omega are the initial state)")                                   \
  GM_PARAMETERS_GEAR_DYNAMICS(X, A, 1, 0)                                                                            \
  GM_PARAMETERS_GEAR_DYNAMICS(X, A, 2, 1)                                                                            \
  X(A, "dynamics.tolerance", parameter, Real, DYNAMICS, tolerance, "m", "um", 1e-14, 1e-4, GM_CLOSED, GM_ALL_LEVELS, \
    GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0, "large-step mode: local error of r_b phi per internal step")         \
  X(A, "dynamics.max_step", parameter, Real, DYNAMICS, max_step, "s", "", 1e-9, 1.0, GM_CLOSED, GM_ALL_LEVELS,       \
    GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0, "large-step mode: longest internal step")                            \
  X(A, "dynamics.min_step", parameter, Real, DYNAMICS, min_step, "s", "", 1e-15, 1.0, GM_CLOSED, GM_ALL_LEVELS,      \
    GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0,                                                                     \
    "large-step mode: shortest internal step before fmi2DoStep returns fmi2Discard (<= dynamics.max_step)")       \
  X(A, "dynamics.mesh_damping_ratio", parameter, Real, HOST, mesh_damping_ratio, "", "", 0, 10.0, GM_CLOSED,         \
    GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0,                                                      \
    "large-step mode: damping ratio of the mesh mode at ISO 6336-1's mean mesh stiffness and the gears' "         \
    "inertias; adds dynamics.mesh_damping to model.damping (0 = model.damping alone)")                            \
  X(A, "dynamics.mesh_damping", calculated, Real, HOST, mesh_damping, "N.s/m2", "", 0, 0, GM_NO_RANGE,               \
    GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_GEOMETRY | GM_GROUP_SETTING | GM_GROUP_DYNAMICS, 0,               \
    "large-step mode: the contact damping dynamics.mesh_damping_ratio adds to model.damping")                     \
  X(A, "dynamics.order_cycles", parameter, Integer, DYNAMICS, order_cycles, "", "", 1, GM_ORDER_CYCLES_MAX,          \
    GM_CLOSED, GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0,                                           \
    "large-step mode: mesh cycles the mesh orders (mesh.te_order<k>) average over")                                \
  X(A, "dynamics.mesh_orders", parameter, Integer, DYNAMICS, mesh_orders, "", "", 3, GM_MESH_ORDERS_MAX,            \
    GM_CLOSED, GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, GM_PARAM_STRUCTURAL,                         \
    "large-step mode: mesh orders computed, 1 to this (the arrays mesh.te_orders and the others; the scalars "   \
    "mesh.te_order1 ... 3 are their first three)")                                                               \
  X(A, "dynamics.step_sensitivities", parameter, Boolean, HOST, step_sensitivities, "", "", 0, 1, GM_NO_RANGE,       \
    GM_ALL_LEVELS, GM_MODE_LARGE_STEP, GM_GROUP_DYNAMICS, 0,                                                      \
    "large-step mode: fmi2GetDirectionalDerivative gives the last step's sensitivities, d(value at its end) / "   \
    "d(gear<i>.torque, .shaft_phi, .shaft_omega held over it), instead of the partials at the point")

typedef enum { GM_PARAM_Real,
               GM_PARAM_Integer,
               GM_PARAM_Boolean,
               GM_PARAM_String } gm_param_type;
typedef enum { GM_PARAM_IN_MODEL,
               GM_PARAM_IN_DYNAMICS,
               GM_PARAM_IN_HOST } gm_param_where;

/* One row of GM_PARAMETERS as data. */
typedef struct gm_param_info {
  const char* name;         /* e.g. "gear1.teeth" */
  int calculated;           /* 0 parameter, 1 calculated by the host */
  gm_param_type type;       /* Real: double; Integer, Boolean: int; String: const char* */
  gm_param_where where;     /* the struct the field is in */
  size_t offset;            /* of the field in gm_model_params or gm_dynamics_params (HOST: 0) */
  const char* unit;         /* "" for none */
  const char* display_unit; /* "" for none */
  double lo, hi;            /* static range in SI; -HUGE_VAL / HUGE_VAL: none */
  int lo_open, hi_open;     /* 1: value > lo (< hi) */
  int has_range;            /* 0: no static range */
  unsigned levels, modes, group, flags;
  const char* description;
} gm_param_info;

/* The whole table (*count rows) and the row of `name` (NULL: no such parameter). */
const gm_param_info* gm_parameters(size_t* count);
const gm_param_info* gm_parameter_find(const char* name);

/* The field of row r in p or dp (by r->where; NULL for HOST rows or a NULL struct). */
void* gm_parameter_field(const gm_param_info* r, gm_model_params* p, gm_dynamics_params* dp);

/* Sets parameter `name` of p or dp to value: GM_OK; GM_ERR_ARGUMENT with msg for an unknown name,
 * a HOST or String row, or a non-whole value of an Integer or Boolean. The value is not range
 * checked here (gm_model_create and gm_dynamics_check do that). */
gm_status gm_parameter_set(gm_model_params* p, gm_dynamics_params* dp, const char* name, double value, char* msg,
                           size_t msg_size);

/* Static ranges: of every row with one, and of the outputs that declare the values they take
 * (mesh.flank), for modelDescription.xml's min and max. */
typedef struct gm_param_range {
  const char* name; /* FMU variable name */
  double lo, hi;    /* bounds in SI; -HUGE_VAL / HUGE_VAL: none */
  int lo_open;      /* 1: value > lo, 0: value >= lo */
  int hi_open;      /* 1: value < hi, 0: value <= hi */
  const char* unit; /* the variable's unit, "" for none */
} gm_param_range;

/* All of them (*count rows), and the range of FMU variable `name` (NULL: no static range). */
const gm_param_range* gm_param_ranges(size_t* count);
const gm_param_range* gm_param_range_find(const char* name);

/* GM_OK when value is finite and inside r; else GM_ERR_PARAMETER with
 * msg = "<name> = <value> <unit>: allowed range [lo, hi] <unit>" (round brackets at open or
 * missing bounds). */
gm_status gm_param_range_check(const gm_param_range* r, double value, char* msg, size_t msg_size);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_PARAMETERS_H */
