/* The FMU's variables, units and log categories: the single source of the C value-reference
 * table (fmu_src), modelDescription.xml (generate_model_description.c) and the FMU state
 * serialization. Adding a variable is one line here; the GUID is a hash of this file, so a
 * binary and a modelDescription.xml built from different versions of it never pair up.
 *
 * Start values are not written here: parameters start at gm_default_params() (the core owns
 * the defaults), inputs at 0 (nominal pose, at rest). A scene FMU (tools/gearmesh/scene_fmu.py)
 * overrides some of them: it rewrites their start attributes in modelDescription.xml and lists
 * the same values in resources/gearmesh-start-values.txt, which the binary reads at
 * fmi2Instantiate (model.h, model_set_resources).
 *
 * Types: a Real is bound to a double, an Integer or Boolean to an int, a String to a
 * const char* that the FMU instance owns (NULL = ""; copied on fmi2SetString).
 */
#ifndef GEARMESH_FMU_VARIABLES_H
#define GEARMESH_FMU_VARIABLES_H

#include <stddef.h>

#include "gearmesh/gearmesh.h"

/* Every value of an FMU instance; each variable is bound to one field. */
typedef struct gm_fmu_values {
  gm_model_params p;     /* parameters */
  int dynamics;          /* parameter model.dynamics: 0 prescribed motion, 1 large-step */
  gm_dynamics_params dp; /* parameters of the large-step dynamics */
  gm_pair_geometry g;    /* calculated parameters, from the core model */
  gm_kinematics k;       /* inputs, held over a step */
  gm_dynamics_inputs di; /* inputs of the large-step dynamics, held over a step */
  gm_result y;           /* outputs published by the last evaluation */
  gm_dynamics_state ds;  /* outputs: the spin state and energy account (the dynamics' state) */
} gm_fmu_values;

typedef enum { GM_FMU_Real, GM_FMU_Integer, GM_FMU_Boolean, GM_FMU_String } gm_fmu_type;
typedef enum {
  GM_FMU_parameter,
  GM_FMU_calculatedParameter,
  GM_FMU_input,
  GM_FMU_output
} gm_fmu_causality;

/* Dependency classes for <ModelStructure> (docs/fmi.md, "Feedthrough"). A known (parameter,
 * input) names its class. An unknown (output, calculated parameter) names the classes it depends
 * on at a communication point (<Outputs>: the knowns are the inputs) and, through D_AT_INIT,
 * those it depends on only in Initialization Mode (<InitialUnknowns>: inputs and parameters).
 * Each set is the union over the three modes (plain, quasi-static, large-step): the inputs a
 * mode ignores are declared for the others. tests/python/test_fmu_feedthrough.py measures
 * every output/input pair against them. */
enum {
  D_GEO = 1 << 0,          /* parameter that enters the pair geometry */
  D_SET = 1 << 1,          /* other parameter: micro-geometry, material, stiffness model, friction, solver,
                              model.dynamics */
  D_DYN = 1 << 2,          /* parameter of the large-step dynamics (inertia, shaft, integrator) */
  D_PHI1 = 1 << 3,         /* gear<i>.phi: D_PHI(i - 1) */
  D_POSE = 1 << 5,         /* centre displacement, tilt */
  D_RATE = 1 << 6,         /* centre velocity x, y and tilt rates: friction, damping */
  D_AXIAL_RATE = 1 << 7,   /* gear<i>.vz: damping only (friction slides along the transverse profile
                              tangent, so neither the force solve nor the quasi-static TE sees it) */
  D_OMEGA1 = 1 << 8,       /* gear<i>.omega: D_OMEGA(i - 1) */
  D_SHAFT_PHI1 = 1 << 10,  /* gear<i>.shaft_phi: D_SHAFT_PHI(i - 1) */
  D_SHAFT_OMEGA1 = 1 << 12, /* gear<i>.shaft_omega: D_SHAFT_OMEGA(i - 1) */
  D_LOAD = 1 << 14,        /* mesh.load_torque */
  D_TORQUE = 0,            /* gear<i>.torque: acts over a step; no output depends on it at a point */
  D_INIT_SHIFT = 16,       /* classes << D_INIT_SHIFT: at initialization only */
  D_KNOWN_CLASSES = (1 << D_INIT_SHIFT) - 1,
  /* the contact at prescribed spins (plain), at the solved TE (quasi-static) or at the spin state
   * and the current pose (large-step; gear<i>.phi/.omega set the state at initialization) */
  D_TE = D_GEO | D_SET | D_PHI1 | D_PHI1 << 1 | D_POSE | D_RATE | D_OMEGA1 | D_OMEGA1 << 1 | D_LOAD,
  D_CONTACT = D_TE | D_AXIAL_RATE, /* damping acts on the forces after the solve */
  /* large-step energies at initialization (elsewhere the account of the steps, or 0) */
  D_KINETIC = D_SET | D_DYN | D_OMEGA1 | D_OMEGA1 << 1,
  D_ELASTIC = D_GEO | D_SET | D_DYN | D_PHI1 | D_PHI1 << 1 | D_POSE | D_SHAFT_PHI1 | D_SHAFT_PHI1 << 1
};
#define D_PHI(n) (D_PHI1 << (n))
#define D_OMEGA(n) (D_OMEGA1 << (n))
#define D_SHAFT_PHI(n) (D_SHAFT_PHI1 << (n))
#define D_SHAFT_OMEGA(n) (D_SHAFT_OMEGA1 << (n))
#define D_AT_INIT(classes) ((unsigned)(classes) << D_INIT_SHIFT)

/* Unit definitions: name and SI base exponents (kg, m, s, rad). */
#define GM_FMU_UNITS(U)   \
  U("m", 0, 1, 0, 0)      \
  U("rad", 0, 0, 0, 1)    \
  U("N", 1, 1, -2, 0)     \
  U("N.m", 1, 2, -2, 0)   \
  U("m/s", 0, 1, -1, 0)   \
  U("rad/s", 0, 0, -1, 1) \
  U("Pa", 1, -1, -2, 0)   \
  U("N/m", 1, 0, -2, 0)   \
  U("N/m2", 1, -1, -2, 0) \
  U("N.s/m2", 1, -1, -1, 0) \
  U("W", 1, 2, -3, 0)     \
  U("J", 1, 2, -2, 0)     \
  U("s", 0, 0, 1, 0)      \
  U("kg.m2", 1, 2, 0, 0)  \
  U("N.m/rad", 1, 2, -2, -1) \
  U("N.m.s/rad", 1, 2, -1, -1)

/* Display units: unit, name, factor (display value = factor * SI value). */
#define GM_FMU_DISPLAY_UNITS(D)               \
  D("m", "mm", 1e3)                           \
  D("m", "um", 1e6)                           \
  D("rad", "deg", 57.295779513082323)         \
  D("rad", "mrad", 1e3)                       \
  D("N", "kN", 1e-3)                          \
  D("N.m", "N.mm", 1e3)                       \
  D("m/s", "mm/s", 1e3)                       \
  D("rad/s", "rpm", 9.5492965855137202)       \
  D("Pa", "MPa", 1e-6)                        \
  D("Pa", "GPa", 1e-9)                        \
  D("N/m", "N/mm", 1e-3)                      \
  D("N/m", "N/um", 1e-6)                      \
  D("N/m2", "N/(mm.um)", 1e-9)                \
  D("N.s/m2", "N.s/mm2", 1e-6)                \
  D("W", "kW", 1e-3)

/* Log categories: enum id, name, description. Errors are logged whatever is enabled. */
#define GM_FMU_LOG_CATEGORIES(L)                                                        \
  L(GM_LOG_EVENTS, "logEvents", "mode changes, resource location")                     \
  L(GM_LOG_WARNING, "logStatusWarning", "calls that return fmi2Warning")                \
  L(GM_LOG_ERROR, "logStatusError", "calls that return fmi2Error (always logged)")     \
  L(GM_LOG_FATAL, "logStatusFatal", "calls that return fmi2Fatal (always logged)")     \
  L(GM_LOG_ALL, "logAll", "enables every category")                                    \
  L(GM_LOG_CONTACT, "contact", "tooth pairs and flank in contact when they change")    \
  L(GM_LOG_SOLVER, "solver", "iterations and residual of every force solve")

typedef enum {
#define L(id, name, description) id,
  GM_FMU_LOG_CATEGORIES(L)
#undef L
  GM_LOG_COUNT
} gm_log_category;

/* Micro-geometry of gear i (docs/physics.md §2), one set per gear for BOTH flanks: the rows are bound to
 * flank A, p.gear[n].flank[0], and the model binding copies flank[0] to flank[1] just before
 * gm_model_create (model_gearmesh.c, core_params). Asymmetric or per-tooth deviations come
 * through the deviation file (gear<i>.deviations). One line per variable:
 * F(X, i, n, field = FMU name suffix, type, unit, display unit, description). */
#define GM_FMU_FLANK(X, i, n, field, type, unit, dunit, desc)                                                       \
  X("gear" #i "." #field, type, parameter, fixed, exact, unit, dunit, p.gear[n].flank[0].field, D_SET,             \
    desc "; applied to flank A and flank B")
#define GM_FMU_GEAR_MICROGEOMETRY(X, i, n)                                                                          \
  GM_FMU_FLANK(X, i, n, profile_crowning, Real, "m", "um",                                                          \
               "profile crowning C_alpha: parabola over the active profile, C at both ends")                        \
  GM_FMU_FLANK(X, i, n, tip_relief, Real, "m", "um", "tip relief C_a at the tip")                                   \
  GM_FMU_FLANK(X, i, n, tip_relief_length, Real, "m", "mm",                                                        \
               "roll length L_a of the tip relief from the tip (while C_a != 0: > 0 and <= the active profile)")     \
  GM_FMU_FLANK(X, i, n, tip_relief_parabolic, Boolean, "", "",                                                      \
               "tip relief shape: false linear, true parabolic")                                                    \
  GM_FMU_FLANK(X, i, n, root_relief, Real, "m", "um", "root relief C_f at the start of active profile")             \
  GM_FMU_FLANK(X, i, n, root_relief_length, Real, "m", "mm",                                                        \
               "roll length L_f of the root relief from the start of active profile (while C_f != 0: > 0 and "      \
               "<= the active profile less L_a)")                                                                   \
  GM_FMU_FLANK(X, i, n, root_relief_parabolic, Boolean, "", "",                                                     \
               "root relief shape: false linear, true parabolic")                                                   \
  GM_FMU_FLANK(X, i, n, profile_slope, Real, "m", "um",                                                             \
               "profile slope f_Halpha: gap at the tip minus gap at the start")                                     \
  GM_FMU_FLANK(X, i, n, lead_crowning, Real, "m", "um", "lead crowning C_beta: parabola, C at both face ends")      \
  GM_FMU_FLANK(X, i, n, helix_slope, Real, "m", "um",                                                               \
               "helix slope f_Hbeta: gap at face end y = +b/2 minus gap at y = -b/2")                               \
  GM_FMU_FLANK(X, i, n, end_relief, Real, "m", "um", "end relief C_I at both face ends, linear")                    \
  GM_FMU_FLANK(X, i, n, end_relief_length, Real, "m", "mm",                                                        \
               "length of the end relief from each face end (while C_I != 0: > 0 and <= b/2)")

/* Parameters of gear i (field index n = i - 1). */
#define GM_FMU_GEAR_PARAMETERS(X, i, n)                                                                            \
  X("gear" #i ".teeth", Integer, parameter, fixed, exact, "", "", p.gear[n].teeth, D_GEO,                          \
    "number of teeth z (magnitude; an internal ring is flagged by pair.internal)")                                 \
  X("gear" #i ".profile_shift", Real, parameter, fixed, exact, "", "", p.gear[n].profile_shift, D_GEO,             \
    "profile shift coefficient x")                                                                                 \
  X("gear" #i ".face_width", Real, parameter, fixed, exact, "m", "mm", p.gear[n].face_width, D_GEO,                \
    "face width b")                                                                                                \
  X("gear" #i ".tip_diameter", Real, parameter, fixed, exact, "m", "mm", p.gear[n].tip_diameter, D_GEO,            \
    "tip diameter d_a (ring: inner diameter); 0 = from the basic rack")                                            \
  X("gear" #i ".thickness_allowance", Real, parameter, fixed, exact, "m", "um",                                    \
    p.gear[n].thickness_allowance, D_GEO, "normal tooth thickness allowance E_sn (>= -0.5 pair.normal_module)")    \
  X("gear" #i ".axial_offset", Real, parameter, fixed, exact, "m", "mm", p.gear[n].axial_offset, D_GEO,            \
    "mid-face position along the gear axis from the gear centre")                                                  \
  X("gear" #i ".youngs_modulus", Real, parameter, fixed, exact, "Pa", "GPa", p.gear[n].youngs_modulus,             \
    D_SET, "Young's modulus E")                                                                                    \
  X("gear" #i ".poisson_ratio", Real, parameter, fixed, exact, "", "", p.gear[n].poisson_ratio, D_SET,             \
    "Poisson's ratio nu")                                                                                          \
  GM_FMU_GEAR_MICROGEOMETRY(X, i, n)                                                                               \
  X("gear" #i ".deviations", String, parameter, fixed, exact, "", "", p.gear[n].deviations, D_SET,                 \
    "file name of a flank deviation file (measured grids, pitch; per tooth and flank) inside the FMU's "           \
    "resources/ folder, \"\" = none; relative, without \"..\" or backslashes")                                     \
  X("gear" #i ".compliance", String, parameter, fixed, exact, "", "", p.compliance[n], D_SET,                     \
    "level 5 (required there, \"\" at other levels): file name of this gear's compliance database (.gcdb, "      \
    "made by compliance_tool for this gear) inside the FMU's resources/ folder; relative, without \"..\" or "    \
    "backslashes")

/* Calculated parameters of gear i. */
#define GM_FMU_GEAR_GEOMETRY(X, i, n)                                                                              \
  X("gear" #i ".base_diameter", Real, calculatedParameter, fixed, calculated, "m", "mm", g.gear[n].d_b,            \
    D_GEO, "base diameter d_b")                                                                                    \
  X("gear" #i ".tip_diameter_used", Real, calculatedParameter, fixed, calculated, "m", "mm",                       \
    g.gear[n].d_a, D_GEO, "tip diameter d_a actually used (ring: inner diameter)")                                 \
  X("gear" #i ".form_diameter", Real, calculatedParameter, fixed, calculated, "m", "mm", g.gear[n].d_Ff,           \
    D_GEO, "root form diameter d_Ff")

/* Inputs of gear i, in the housing frame H (docs/physics.md §0). */
#define GM_FMU_GEAR_INPUTS(X, i, n)                                                                                 \
  X("gear" #i ".ux", Real, input, continuous, exact, "m", "um", k.u[n][0], D_POSE, "centre displacement x") \
  X("gear" #i ".uy", Real, input, continuous, exact, "m", "um", k.u[n][1], D_POSE, "centre displacement y") \
  X("gear" #i ".uz", Real, input, continuous, exact, "m", "um", k.u[n][2], D_POSE, "centre displacement z") \
  X("gear" #i ".rx", Real, input, continuous, exact, "rad", "mrad", k.r[n][0], D_POSE, "tilt about H's x")  \
  X("gear" #i ".ry", Real, input, continuous, exact, "rad", "mrad", k.r[n][1], D_POSE, "tilt about H's y")  \
  X("gear" #i ".phi", Real, input, continuous, exact, "rad", "deg", k.phi[n], D_PHI(n),                     \
    "spin angle about the gear's own axis, |phi| <= 1e7 rad")                                                       \
  X("gear" #i ".vx", Real, input, continuous, exact, "m/s", "mm/s", k.v[n][0], D_RATE, "centre velocity x") \
  X("gear" #i ".vy", Real, input, continuous, exact, "m/s", "mm/s", k.v[n][1], D_RATE, "centre velocity y") \
  X("gear" #i ".vz", Real, input, continuous, exact, "m/s", "mm/s", k.v[n][2], D_AXIAL_RATE,                     \
    "centre velocity z")                                                                                           \
  X("gear" #i ".wx", Real, input, continuous, exact, "rad/s", "", k.w[n][0], D_RATE, "tilt rate about x")   \
  X("gear" #i ".wy", Real, input, continuous, exact, "rad/s", "", k.w[n][1], D_RATE, "tilt rate about y")   \
  X("gear" #i ".omega", Real, input, continuous, exact, "rad/s", "rpm", k.omega[n], D_OMEGA(n),                   \
    "spin rate")

/* Large-step dynamics of gear i (core/src/dynamics.hpp): parameters, inputs, outputs. */
#define GM_FMU_GEAR_DYNAMICS_PARAMETERS(X, i, n)                                                                   \
  X("gear" #i ".inertia", Real, parameter, fixed, exact, "kg.m2", "", dp.inertia[n], D_DYN,         \
    "large-step mode: moment of inertia about the spin axis")                                               \
  X("gear" #i ".shaft_stiffness", Real, parameter, fixed, exact, "N.m/rad", "", dp.shaft_stiffness[n], \
    D_DYN, "large-step mode: torsional stiffness of the shaft from the gear to its far end (0 = no shaft)")        \
  X("gear" #i ".shaft_damping", Real, parameter, fixed, exact, "N.m.s/rad", "", dp.shaft_damping[n],   \
    D_DYN, "large-step mode: torsional damping of that shaft")
#define GM_FMU_GEAR_DYNAMICS_INPUTS(X, i, n)                                                                       \
  X("gear" #i ".torque", Real, input, continuous, exact, "N.m", "", di.torque[n], D_TORQUE,                \
    "large-step mode: external torque on the gear about its spin axis (+z), held over the step")                 \
  X("gear" #i ".shaft_phi", Real, input, continuous, exact, "rad", "deg", di.shaft_phi[n], D_SHAFT_PHI(n), \
    "large-step mode: angle of the shaft's far end at the start of the step")                                    \
  X("gear" #i ".shaft_omega", Real, input, continuous, exact, "rad/s", "rpm", di.shaft_omega[n],         \
    D_SHAFT_OMEGA(n),                                                                                            \
    "large-step mode: speed of the shaft's far end, which moves as shaft_phi + shaft_omega (t - t_c)")
#define GM_FMU_GEAR_DYNAMICS_OUTPUTS(X, i, n)                                                                      \
  X("gear" #i ".angle", Real, output, continuous, calculated, "rad", "deg", ds.phi[n], D_PHI(n),          \
    "spin angle at the end of the step (large-step mode: integrated; else the input gear" #i ".phi)")            \
  X("gear" #i ".speed", Real, output, continuous, calculated, "rad/s", "rpm", ds.omega[n], D_OMEGA(n),      \
    "spin speed at the end of the step (large-step mode: integrated; else the input gear" #i ".omega)")          \
  X("gear" #i ".shaft_torque", Real, output, continuous, calculated, "N.m", "", ds.shaft_torque[n],         \
    D_AT_INIT(D_SET | D_DYN | D_PHI(n) | D_OMEGA(n) | D_SHAFT_PHI(n) | D_SHAFT_OMEGA(n)),                       \
    "large-step mode: torque of the shaft on the gear at the end of the step (its far end feels minus this)")

/* Outputs of gear i. */
#define GM_FMU_GEAR_OUTPUTS(X, i, n)                                                                               \
  X("gear" #i ".fx", Real, output, continuous, calculated, "N", "kN", y.force[n][0], D_CONTACT,                    \
    "contact force on the gear, x in H")                                                                           \
  X("gear" #i ".fy", Real, output, continuous, calculated, "N", "kN", y.force[n][1], D_CONTACT,                    \
    "contact force on the gear, y in H")                                                                           \
  X("gear" #i ".fz", Real, output, continuous, calculated, "N", "kN", y.force[n][2], D_CONTACT,                    \
    "contact force on the gear, z in H")                                                                           \
  X("gear" #i ".mx", Real, output, continuous, calculated, "N.m", "", y.moment[n][0], D_CONTACT,                   \
    "contact moment about the gear centre, x in H")                                                                \
  X("gear" #i ".my", Real, output, continuous, calculated, "N.m", "", y.moment[n][1], D_CONTACT,                   \
    "contact moment about the gear centre, y in H")                                                                \
  X("gear" #i ".mz", Real, output, continuous, calculated, "N.m", "", y.moment[n][2], D_CONTACT,                   \
    "contact moment about the gear centre, z in H")

/* X(name, type, causality, variability, initial, unit, displayUnit, field of gm_fmu_values,
 *   dependency class, description). Value reference = position in this list. min and max are not
 *   here: modelDescription.xml takes them from the core's range table (core/src/param_ranges.cpp). */
#define GM_FMU_VARIABLES(X)                                                                                        \
  X("pair.center_distance", Real, parameter, fixed, exact, "m", "mm", p.pair.center_distance, D_GEO,               \
    "operating centre distance a (positive also for internal pairs)")                                              \
  X("pair.normal_module", Real, parameter, fixed, exact, "m", "mm", p.pair.normal_module, D_GEO,                   \
    "normal module m_n")                                                                                           \
  X("pair.pressure_angle", Real, parameter, fixed, exact, "rad", "deg", p.pair.pressure_angle, D_GEO,              \
    "normal pressure angle alpha_n")                                                                               \
  X("pair.helix_angle", Real, parameter, fixed, exact, "rad", "deg", p.pair.helix_angle, D_GEO,                    \
    "helix angle beta of gear 1 (sign = hand, + right)")                                                           \
  X("pair.internal", Boolean, parameter, fixed, exact, "", "", p.pair.internal, D_GEO,                             \
    "gear 2 is an internal ring")                                                                                  \
  X("pair.rack_addendum", Real, parameter, fixed, exact, "", "", p.pair.rack_addendum, D_GEO,                      \
    "basic rack addendum h_aP*, in modules")                                                                       \
  X("pair.rack_dedendum", Real, parameter, fixed, exact, "", "", p.pair.rack_dedendum, D_GEO,                      \
    "basic rack dedendum h_fP*, in modules (> pair.rack_addendum)")                                                \
  X("pair.rack_tip_radius", Real, parameter, fixed, exact, "", "", p.pair.rack_tip_radius, D_GEO,                  \
    "basic rack tip radius rho_fP*, in modules (<= 1.01 times the full round (h_fP* - h_aP*)/(1 - sin alpha_n))")  \
  GM_FMU_GEAR_PARAMETERS(X, 1, 0)                                                                                  \
  GM_FMU_GEAR_PARAMETERS(X, 2, 1)                                                                                  \
  X("model.stiffness", Integer, parameter, fixed, exact, "", "", p.stiffness_level, D_SET,                         \
    "stiffness level: 0 user constant, 1 user tables, 2 ISO 6336, 3 time-varying, 4 analytical, 5 FE")             \
  X("model.user_stiffness", Real, parameter, fixed, exact, "N/m2", "N/(mm.um)", p.user_stiffness, D_SET,           \
    "mesh stiffness per unit face width (level 0)")                                                                \
  X("model.stiffness_table", String, parameter, fixed, exact, "", "", p.stiffness_table, D_SET,                    \
    "level 1 (required there, \"\" at other levels): file name of a stiffness table (pair stiffness per unit "     \
    "face width over gear 1's roll angle) inside the FMU's resources/ folder; relative, without \"..\" or "        \
    "backslashes")                                                                                                 \
  X("model.te_table", String, parameter, fixed, exact, "", "", p.te_table, D_SET,                                  \
    "any level: file name of a TE excitation table (over gear 1's angle within one pitch; opens both flanks by "   \
    "it) inside the FMU's resources/ folder, \"\" = none; relative, without \"..\" or backslashes")              \
  X("model.slices", Integer, parameter, fixed, exact, "", "", p.slices, D_SET,                                     \
    "slices across the axial overlap")                                                                             \
  X("model.coupled_teeth", Integer, parameter, fixed, exact, "", "", p.coupled_teeth, D_SET,                       \
    "levels 4 and 5: neighbouring teeth coupled on each side (level 4: at most 3, 0 = uncoupled)")                 \
  X("model.friction_coefficient", Real, parameter, fixed, exact, "", "", p.friction_coefficient, D_SET,            \
    "friction coefficient mu")                                                                                     \
  X("model.friction_velocity", Real, parameter, fixed, exact, "m/s", "mm/s", p.friction_velocity, D_SET,           \
    "friction regularization velocity v0")                                                                         \
  X("model.damping", Real, parameter, fixed, exact, "N.s/m2", "", p.damping, D_SET,                                \
    "normal damping per unit face width")                                                                          \
  X("solver.tolerance", Real, parameter, fixed, exact, "m", "um", p.solver_tolerance, D_SET,                       \
    "tolerance of the force solve on the approach")                                                                \
  X("solver.max_iterations", Integer, parameter, fixed, exact, "", "", p.solver_max_iterations, D_SET,             \
    "iteration cap of the force solve")                                                                            \
  X("model.rated_line_load", Real, parameter, fixed, exact, "N/m", "N/mm", p.rated_line_load, D_SET,               \
    "level 2: F_t K_A/b for ISO 6336-1's load correction of c' (0 = none)")                                       \
  X("model.quasi_static", Boolean, parameter, fixed, exact, "", "", p.quasi_static, D_SET,                         \
    "solve gear 2's spin for mesh.load_torque (gear2.phi is then ignored)")                                       \
  X("model.dynamics", Integer, parameter, fixed, exact, "", "", dynamics, D_SET,                                  \
    "0 prescribed motion (spins are inputs); 1 large-step: both spins integrated inside fmi2DoStep from "          \
    "gear<i>.torque and the shafts (gear<i>.phi/.omega are the initial state)")                                  \
  GM_FMU_GEAR_DYNAMICS_PARAMETERS(X, 1, 0)                                                                         \
  GM_FMU_GEAR_DYNAMICS_PARAMETERS(X, 2, 1)                                                                         \
  X("dynamics.tolerance", Real, parameter, fixed, exact, "m", "um", dp.tolerance, D_DYN,         \
    "large-step mode: local error of r_b phi per internal step")                                                 \
  X("dynamics.max_step", Real, parameter, fixed, exact, "s", "", dp.max_step, D_DYN,                 \
    "large-step mode: longest internal step")                                                                     \
  X("dynamics.min_step", Real, parameter, fixed, exact, "s", "", dp.min_step, D_DYN,                \
    "large-step mode: shortest internal step before fmi2DoStep returns fmi2Discard (<= dynamics.max_step)")      \
  X("geometry.backlash", Real, calculatedParameter, fixed, calculated, "m", "um", g.j_bt, D_GEO,                   \
    "transverse backlash along the line of action j_bt")                                                           \
  X("geometry.circumferential_backlash", Real, calculatedParameter, fixed, calculated, "m", "um", g.j_wt,          \
    D_GEO, "circumferential backlash at the operating pitch circles j_wt")                                         \
  X("geometry.operating_pressure_angle", Real, calculatedParameter, fixed, calculated, "rad", "deg",               \
    g.alpha_wt, D_GEO, "operating transverse pressure angle alpha_wt")                                             \
  X("geometry.contact_ratio", Real, calculatedParameter, fixed, calculated, "", "", g.eps_alpha, D_GEO,            \
    "transverse contact ratio eps_alpha")                                                                          \
  X("geometry.overlap_ratio", Real, calculatedParameter, fixed, calculated, "", "", g.eps_beta, D_GEO,             \
    "overlap ratio eps_beta")                                                                                      \
  X("geometry.base_pitch", Real, calculatedParameter, fixed, calculated, "m", "mm", g.p_bt, D_GEO,                 \
    "transverse base pitch p_bt")                                                                                  \
  X("geometry.tight_center_distance", Real, calculatedParameter, fixed, calculated, "m", "mm", g.a_tight,          \
    D_GEO, "centre distance of a zero-backlash mesh a_tight")                                                      \
  GM_FMU_GEAR_GEOMETRY(X, 1, 0)                                                                                    \
  GM_FMU_GEAR_GEOMETRY(X, 2, 1)                                                                                    \
  GM_FMU_GEAR_INPUTS(X, 1, 0)                                                                                      \
  GM_FMU_GEAR_INPUTS(X, 2, 1)                                                                                      \
  X("mesh.load_torque", Real, input, continuous, exact, "N.m", "", k.load_torque, D_LOAD,                         \
    "quasi-static mode: torque of gear 2's load against the flank-A drive (+ loads flank A)")                      \
  GM_FMU_GEAR_DYNAMICS_INPUTS(X, 1, 0)                                                                             \
  GM_FMU_GEAR_DYNAMICS_INPUTS(X, 2, 1)                                                                             \
  GM_FMU_GEAR_OUTPUTS(X, 1, 0)                                                                                     \
  GM_FMU_GEAR_OUTPUTS(X, 2, 1)                                                                                     \
  X("mesh.te", Real, output, continuous, calculated, "m", "um", y.te, D_TE,                                        \
    "transmission error along the line of action")                                                                 \
  X("mesh.te_angle", Real, output, continuous, calculated, "rad", "deg", y.te_angle, D_TE,                         \
    "transmission error as an angle of gear 2")                                                                    \
  X("mesh.normal_force", Real, output, continuous, calculated, "N", "kN", y.normal_force, D_CONTACT,                \
    "sum of the normal slice forces")                                                                              \
  X("mesh.stiffness", Real, output, continuous, calculated, "N/m", "N/um", y.stiffness, D_TE,              \
    "tangent mesh stiffness along the line of action")                                                             \
  X("mesh.pairs_in_contact", Integer, output, discrete, calculated, "", "", y.pairs_in_contact, D_CONTACT,         \
    "loaded tooth pairs")                                                                                          \
  X("mesh.flank", Integer, output, discrete, calculated, "", "", y.flank, D_CONTACT,                               \
    "flank in contact: 0 none, 1 flank A, 2 flank B, 3 both")                                                      \
  X("mesh.friction_power", Real, output, continuous, calculated, "W", "", y.friction_power, D_CONTACT,             \
    "power dissipated by friction")                                                                                \
  X("mesh.max_line_load", Real, output, continuous, calculated, "N/m", "N/mm", y.max_line_load, D_CONTACT,         \
    "largest slice line load")                                                                                     \
  X("mesh.max_load_share", Real, output, continuous, calculated, "", "", y.max_load_share, D_CONTACT,              \
    "share of mesh.normal_force carried by the most loaded tooth pair (0 without contact)")                       \
  X("solver.iterations", Integer, output, discrete, calculated, "", "", y.solver_iterations, D_TE,         \
    "iterations of the last force solve (0 = closed form)")                                                        \
  X("solver.residual", Real, output, continuous, calculated, "m", "um", y.solver_residual, D_TE,           \
    "residual of the last force solve")                                                                            \
  X("mesh.elastic_energy", Real, output, continuous, calculated, "J", "", y.elastic_energy, D_TE,          \
    "elastic energy stored in the loaded slices")                                                                  \
  X("mesh.damping_power", Real, output, continuous, calculated, "W", "", y.damping_power, D_CONTACT,               \
    "power dissipated by the contact damping")                                                                     \
  GM_FMU_GEAR_DYNAMICS_OUTPUTS(X, 1, 0)                                                                            \
  GM_FMU_GEAR_DYNAMICS_OUTPUTS(X, 2, 1)                                                                            \
  X("energy.kinetic", Real, output, continuous, calculated, "J", "", ds.kinetic, D_AT_INIT(D_KINETIC),      \
    "large-step mode: kinetic energy of the two gears' spins")                                                     \
  X("energy.elastic", Real, output, continuous, calculated, "J", "", ds.elastic, D_AT_INIT(D_ELASTIC),      \
    "large-step mode: elastic energy in the mesh and the shafts")                                                  \
  X("energy.initial", Real, output, continuous, calculated, "J", "", ds.initial_energy,                     \
    D_AT_INIT(D_KINETIC | D_ELASTIC),                                                                              \
    "large-step mode: kinetic + elastic energy when initialization ended")                                         \
  X("energy.work_in", Real, output, continuous, calculated, "J", "", ds.work_in, 0,                        \
    "large-step mode: work put in by the torques and the shafts' far ends since initialization")                  \
  X("energy.work_out", Real, output, continuous, calculated, "J", "", ds.work_out, 0,                      \
    "large-step mode: work taken out by them (a brake, a load) since initialization")                             \
  X("energy.friction", Real, output, continuous, calculated, "J", "", ds.friction, 0,                      \
    "large-step mode: energy dissipated by friction since initialization")                                         \
  X("energy.damping", Real, output, continuous, calculated, "J", "", ds.damping, 0,                        \
    "large-step mode: energy dissipated by the contact and shaft dampers since initialization")                   \
  X("energy.parametric", Real, output, continuous, calculated, "J", "", ds.parametric, 0,                  \
    "large-step mode: work of the contact forces beyond the mesh's energy change, friction and damping (the "     \
    "element's non-conservative part: compliance varying along the path)")                                       \
  X("energy.residual", Real, output, continuous, calculated, "J", "", ds.residual, 0,                      \
    "large-step mode: integration error, work_in - work_out - (kinetic + elastic - initial) - friction - damping " \
    "- parametric")                                                                                                \
  X("dynamics.step_size", Real, output, continuous, calculated, "s", "", ds.step, D_AT_INIT(D_SET | D_DYN),   \
    "large-step mode: the internal step the next fmi2DoStep tries first")                                         \
  X("dynamics.steps", Integer, output, discrete, calculated, "", "", ds.steps, 0,                          \
    "large-step mode: internal steps accepted in the last fmi2DoStep")                                            \
  X("dynamics.rejected", Integer, output, discrete, calculated, "", "", ds.rejected, 0,                    \
    "large-step mode: internal steps rejected in the last fmi2DoStep (error, Newton, contact changes)")

/* One row of the table as data, for the value-reference table and the generator. */
typedef struct gm_fmu_variable {
  const char* name;
  gm_fmu_type type;
  gm_fmu_causality causality;
  const char* type_name;
  const char* causality_name;
  const char* variability;
  const char* initial;
  const char* unit;
  const char* display_unit;
  size_t offset; /* of the bound field in gm_fmu_values */
  unsigned deps;
  const char* description;
} gm_fmu_variable;

#define GM_FMU_VARIABLE_ROW(name, type, caus, var, init, unit, dunit, field, deps, desc)                    \
  {name, GM_FMU_##type, GM_FMU_##caus, #type, #caus, #var, #init, unit, dunit,                             \
   offsetof(gm_fmu_values, field), deps, desc},

static const gm_fmu_variable gm_fmu_variables[] = {GM_FMU_VARIABLES(GM_FMU_VARIABLE_ROW)};

#define GM_FMU_VARIABLE_COUNT (sizeof gm_fmu_variables / sizeof gm_fmu_variables[0])

/* A Real is bound to a double, an Integer or Boolean to an int, a String to a const char*:
 * checked at compile time. */
#define GM_FMU_CTYPE_Real double
#define GM_FMU_CTYPE_Integer int
#define GM_FMU_CTYPE_Boolean int
#define GM_FMU_CTYPE_String const char*
#define GM_FMU_CHECK_FIELD_TYPE(name, type, caus, var, init, unit, dunit, field, deps, desc)                 \
  _Static_assert(__builtin_types_compatible_p(__typeof__(((gm_fmu_values*)0)->field), GM_FMU_CTYPE_##type), \
                 name " is bound to a field of another C type");
GM_FMU_VARIABLES(GM_FMU_CHECK_FIELD_TYPE)

#endif /* GEARMESH_FMU_VARIABLES_H */
