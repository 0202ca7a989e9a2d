/* GearMesh core: gear-mesh contact element behind a plain C API.
 *
 * Model/data split (MuJoCo style): gm_model is immutable after gm_model_create and holds the
 * geometry and every setting; gm_data is the mutable per-instance state, allocated once.
 * gm_evaluate allocates nothing. No exception crosses this API: every entry point returns a
 * gm_status and the last message is available from the data (or the create call's buffer).
 *
 * Units are SI throughout (m, rad, N, N*m, s, Pa). Frames and signs: docs/physics.md §0.
 */
#ifndef GEARMESH_H
#define GEARMESH_H

#include <stddef.h>

#include "gearmesh/outputs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum gm_status {
  GM_OK = 0,
  GM_ERR_PARAMETER = 1, /* a model parameter is out of its allowed range */
  GM_ERR_INPUT = 2,     /* an evaluation input is non-finite or outside the detection range */
  GM_ERR_SOLVER = 3,    /* the force solve did not converge */
  GM_ERR_MEMORY = 4,    /* allocation failed at creation */
  GM_ERR_ARGUMENT = 5   /* a NULL pointer or other misuse of the API */
} gm_status;

/* Stiffness model levels (docs/design.md, "Stiffness model levels"). */
typedef enum gm_stiffness_level {
  GM_STIFFNESS_USER_CONSTANT = 0,
  GM_STIFFNESS_USER_VARIABLE = 1,
  GM_STIFFNESS_ISO6336 = 2,
  GM_STIFFNESS_CONTACT_LINE = 3,
  GM_STIFFNESS_ANALYTICAL = 4,
  GM_STIFFNESS_FE = 5,
  GM_STIFFNESS_LEVELS /* how many */
} gm_stiffness_level;

/* Micro-geometry of one flank (docs/physics.md §2): material removed, positive = gap, along the flank
 * normal. Profile terms run over the active profile (start of active profile to tip, roll
 * distance rho), lead terms over the face width (face coordinate y from mid-face). */
typedef struct gm_flank_modification {
  double profile_crowning;   /* C_alpha: parabola, 0 at the middle of the active profile, C at both ends, m */
  double tip_relief;         /* C_a at the tip, m */
  double tip_relief_length;  /* L_a, roll length from the tip over which the relief runs, m */
  int tip_relief_parabolic;  /* 0 linear, 1 parabolic */
  double root_relief;        /* C_f at the start of the active profile, m */
  double root_relief_length; /* L_f, roll length from the start of the active profile, m */
  int root_relief_parabolic; /* 0 linear, 1 parabolic */
  double profile_slope;      /* f_Halpha: gap at the tip minus gap at the start, linear, 0 at the middle, m */
  double lead_crowning;      /* C_beta: parabola, 0 at mid-face, C at both face ends, m */
  double helix_slope;        /* f_Hbeta: gap at y = +b/2 minus gap at y = -b/2, linear, 0 at mid-face, m */
  double end_relief;         /* C_I at both face ends, linear, m */
  double end_relief_length;  /* length from each face end over which the end relief runs, m */
} gm_flank_modification;

/* Parameters of one gear. */
typedef struct gm_gear_params {
  int teeth;                  /* z, number of teeth (magnitude; the ring is flagged on the pair) */
  double profile_shift;       /* x, profile shift coefficient, - */
  double face_width;          /* b, m */
  double tip_diameter;        /* d_a, m; 0 = from the basic rack, d + 2 m_n (h_aP* + x); ring: inner */
  double thickness_allowance; /* E_sn, normal tooth thickness allowance, m, <= 0 */
  double axial_offset;        /* mid-face position along the gear axis from the gear centre, m */
  double youngs_modulus;      /* E, Pa */
  double poisson_ratio;       /* nu, - */
  gm_flank_modification flank[2]; /* micro-geometry of flank A [0] and flank B [1] */
  const char* deviations;     /* path of a flank deviation file (measured grid, pitch), or NULL;
                                 read at gm_model_create, not kept */
} gm_gear_params;

/* Parameters of the pair (shared basic rack). */
typedef struct gm_pair_params {
  double center_distance; /* a, operating centre distance (positive also for internal pairs), m */
  double normal_module;   /* m_n, m */
  double pressure_angle;  /* alpha_n, normal pressure angle, rad */
  double helix_angle;     /* beta of gear 1, rad; sign = hand (+ right) */
  int internal;           /* 0 external pair, 1 gear 2 is an internal ring */
  double rack_addendum;   /* h_aP*, in modules */
  double rack_dedendum;   /* h_fP*, in modules */
  double rack_tip_radius; /* rho_fP*, in modules */
} gm_pair_params;

/* Everything gm_model_create needs. gm_default_params fills the paper's set A (57/57). */
typedef struct gm_model_params {
  gm_pair_params pair;
  gm_gear_params gear[2];
  int stiffness_level;          /* gm_stiffness_level */
  double user_stiffness;        /* level 0: mesh stiffness per unit face width, N/m^2 */
  int slices;                   /* slices across the axial overlap, >= 1 */
  int coupled_teeth;            /* levels 4 and 5: neighbouring teeth coupled each side, >= 0
                                   (level 4: its tooth-coupling table, at most 3 used; 0 = none) */
  double friction_coefficient;  /* mu, - */
  double friction_velocity;     /* regularization velocity v0, m/s */
  double damping;               /* normal damping per unit face width, N*s/m^2 */
  double solver_tolerance;      /* KKT tolerance on the approach, m */
  int solver_max_iterations;    /* hard cap */
  int solver_face_shapes;       /* level 5: load shapes across the face per loaded tooth pair in
                                   the coupled solve (default 3; 0 = every slice an unknown, the
                                   full solve) */
  double rated_line_load;       /* level 2: F_t K_A / b of ISO 6336-1's load correction of c', N/m;
                                   0 = none (c' at full load) */
  int quasi_static;             /* 1: gear 2's spin is solved for the load torque (docs/physics.md §6) */
  const char* stiffness_table;  /* level 1 (required there, refused at other levels): path of a
                                   stiffness table file, pair stiffness per unit face width over
                                   gear 1's roll angle, or NULL; read at gm_model_create, not kept */
  const char* te_table;         /* any level: path of a TE excitation table file over gear 1's
                                   angle within one pitch, or NULL; read at gm_model_create, not
                                   kept. Formats and meaning: core/src/user_tables.hpp */
  const char* compliance[2];    /* level 5 (required there, refused at other levels): path of each
                                   gear's compliance database (.gcdb, core/internal/gearmesh/
                                   internal/compliance_db.hpp), or NULL; read at
                                   gm_model_create, not kept */
} gm_model_params;

/* Derived geometry of one gear (ISO 21771; diameters are magnitudes, also for the ring). */
typedef struct gm_gear_geometry {
  double d;               /* reference diameter, m */
  double d_b;             /* base diameter, m */
  double d_a;             /* tip diameter, m (ring: inner diameter) */
  double d_f;             /* root diameter, m */
  double d_Ff;            /* root form diameter, m */
  double d_w;             /* operating pitch diameter, m */
  double d_sap;           /* start of active profile (ring: the outer end), m */
  double x_E;             /* generating profile shift with the thickness allowance, - */
  double s_t;             /* transverse tooth thickness at d, arc, with allowance, m */
  double eta_b;           /* half angle of the tooth (ring: of the space) at the base circle, rad */
  double rho_a;           /* roll distance of the tip circle, m */
  double rho_Ff;          /* roll distance of the form circle (0 if inside the base circle), m */
  int undercut;           /* 1 if the basic rack undercuts the tooth (docs/physics.md §1) */
  int interference;       /* 1 if the mate's tip reaches below the form circle (d_sap beyond d_Ff) */
} gm_gear_geometry;

/* Derived geometry of the pair at the operating centre distance. */
typedef struct gm_pair_geometry {
  double m_t;                 /* transverse module, m */
  double alpha_t;             /* transverse pressure angle, rad */
  double beta_b;              /* base helix angle, rad (magnitude) */
  double p_bt;                /* transverse base pitch, m */
  double p_bn;                /* normal base pitch, m */
  double a_d;                 /* reference centre distance, m */
  double alpha_wt;            /* operating transverse pressure angle, rad */
  double x_sum_zero_backlash; /* x1 + x2 for zero backlash at a (signed convention for rings) */
  double j_wt;                /* circumferential backlash at the operating pitch circles, m */
  double j_bt;                /* transverse backlash along the line of action, m */
  double a_tight;             /* centre distance of a tight (zero-backlash) mesh, m */
  double T1T2;                /* length of the line of action between the tangency points, m */
  double g_alpha;             /* length of the path of contact, m */
  double eps_alpha;           /* transverse contact ratio, - */
  double eps_beta;            /* overlap ratio, - */
  double path_start;          /* start of the path of contact (A): gear 1's roll distance there, along
                                 the line of action from gear 1's tangency point T1, m */
  double path_end;            /* end of the path of contact (E, gear 1's tip): its roll distance, m */
  double face_overlap;        /* axial overlap of the two face widths (eps_beta's, the slices'), m */
  double c_single;            /* ISO 6336-1 method B single stiffness c' per unit face width, with
                                 model.rated_line_load's load correction (level 2's), N/m^2; 0 where
                                 method B's regression gives no positive q'_min */
  double c_gamma_alpha;       /* its mesh stiffness c_gamma_alpha = c' (0.75 eps_alpha + 0.25), N/m^2 */
  gm_gear_geometry gear[2];
} gm_pair_geometry;

/* Largest spin angle magnitude gm_evaluate accepts, rad: one ulp of the angle stays below
 * 1.9e-9 rad (1.9e-9 r_b of TE); larger angles are refused with GM_ERR_INPUT. */
#define GM_MAX_SPIN_ANGLE 1e7

/* Inputs of one evaluation, in the housing frame H (docs/physics.md §0). Index 0 = gear 1. */
typedef struct gm_kinematics {
  double u[2][3];     /* centre displacement from nominal, m */
  double r[2][2];     /* small tilts about H's x and y, rad */
  double phi[2];      /* spin angle about the gear's own axis, rad, |phi| <= GM_MAX_SPIN_ANGLE */
  double v[2][3];     /* centre velocity, m/s */
  double w[2][2];     /* tilt rates, rad/s */
  double omega[2];    /* spin rate, rad/s */
  double load_torque; /* quasi-static mode: torque of gear 2's load against the flank-A drive
                         (positive loads flank A, negative flank B), N*m; phi[1] is then ignored */
} gm_kinematics;

/* Outputs of one evaluation: the rows of gearmesh/outputs.h (names, units, meaning). */
typedef struct gm_result {
  GM_OUTPUTS(GM_OUTPUT_MEMBER, _)
} gm_result;

typedef struct gm_model gm_model;
typedef struct gm_data gm_data;

/* Fill p with the defaults: the paper's gear set A (57/57, m 2.6 mm, 20 deg, b 23 mm, a 150 mm,
 * x 0.35 each), level 4 (analytical, +-2 coupled teeth) with 10 slices, no friction, no damping
 * (user_stiffness 15 N/(mm um) for level 0). */
void gm_default_params(gm_model_params* p);

/* Compute the pair geometry without creating a model. Validates p like gm_model_create.
 * On error, writes a message naming the parameter and its allowed range into msg. */
gm_status gm_compute_geometry(const gm_model_params* p, gm_pair_geometry* out, char* msg,
                              size_t msg_size);

/* Validate p and build an immutable model. On error *out is NULL and msg says why. */
gm_status gm_model_create(const gm_model_params* p, gm_model** out, char* msg, size_t msg_size);

/* Check p as gm_model_create does, without reading a file or building the model: the static ranges,
 * the rules between parameters, the level's rules (its files given or not; what its build checks
 * without a file, e.g. level 4's coupled teeth and ring), the pair geometry, the micro-geometry's
 * modifications; and, if pose is not NULL, the inputs as gm_evaluate checks them (finite, the spin
 * bound, the tilt bound). GM_OK, or the status and message gm_model_create (gm_evaluate for the
 * pose) gives for the same p. What only the files can say (a file that is missing or malformed, a
 * table that misses the active profile, a database of another gear) passes here. */
gm_status gm_model_check(const gm_model_params* p, const gm_kinematics* pose, char* msg, size_t msg_size);
void gm_model_free(gm_model* m);
/* The model's parameters and derived geometry (valid while m lives). */
const gm_model_params* gm_model_parameters(const gm_model* m);
const gm_pair_geometry* gm_model_geometry(const gm_model* m);
/* Design warnings found at creation (undercut, involute interference, contact ratio below 1),
 * "; "-separated; "" if none. The model is usable; callers must pass these on. */
const char* gm_model_warnings(const gm_model* m);

/* Allocate the per-instance state for m (all scratch included). */
gm_status gm_data_create(const gm_model* m, gm_data** out);
void gm_data_free(gm_data* d);
/* Forget warm-start and friction memory. */
void gm_data_reset(const gm_model* m, gm_data* d);

/* One evaluation: detection, forces, resultants, TE. On error res is left unchanged and
 * gm_data_message(d) names the offending input. */
gm_status gm_evaluate(const gm_model* m, gm_data* d, const gm_kinematics* kin, gm_result* res);

/* Directional derivative of gm_evaluate's outputs at the inputs `at` along the input direction
 * `seed` (every gm_kinematics field, load_torque included, is an input): derivative receives
 * d(output)/d(inputs) . seed for every double output of gm_result, exact on the active set at
 * `at` (the implicit-function theorem on the slice force laws c F + f(F) = Delta, and in
 * quasi-static mode on the load balance as well); integer outputs and solver_residual get 0.
 * Slices that are open stay open: at an active-set change (a slice just touching, a tip edge
 * entering, a clamp switching) this is the one-sided derivative of the side `at` lies on. Where
 * `at` lies on both sides, on a kink (the axial overlap of equal face widths at equal axial
 * positions shrinks whichever way gear 2 moves axially), it is the derivative along +seed,
 * d/dt output(at + t seed) at t = 0+: what a forward difference along the seed gives.
 * Uses d's scratch; the evaluation memory (warm start) is left as it was. On error derivative
 * is left unchanged and gm_data_message(d) says why (the same input errors as gm_evaluate, or a
 * non-finite seed). Costs about three evaluations (five in quasi-static mode). */
gm_status gm_directional_derivative(const gm_model* m, gm_data* d, const gm_kinematics* at,
                                    const gm_kinematics* seed, gm_result* derivative);

/* The evaluation memory of d (warm start, friction memory) as a byte blob, for FMU state.
 * gm_data_state_size gives the blob size; save writes exactly that many bytes; load checks the
 * size and the model fingerprint stored in the blob and returns GM_ERR_ARGUMENT on mismatch. */
size_t gm_data_state_size(const gm_model* m, const gm_data* d);
gm_status gm_data_state_save(const gm_model* m, const gm_data* d, void* buf, size_t size);
gm_status gm_data_state_load(const gm_model* m, gm_data* d, const void* buf, size_t size);

/* ---- Large-step dynamics (core/src/dynamics.hpp; docs/dynamics.md) --------------------------
 * The two gears' spins integrated over a communication step inside the element, for explicit
 * masters at steps far above the mesh period: J_i domega_i/dt = torque_i + shaft_i + M_i,z, with
 * the mesh moment M_i,z of gm_evaluate and an optional torsional shaft to a far end that moves
 * as shaft_phi + shaft_omega (t - t_step start). TR-BDF2 (L-stable, second order, one-step) with
 * Newton on the exact Jacobian (gm_directional_derivative) and error-controlled internal steps. */
typedef struct gm_dynamics_params {
  double inertia[2];         /* J_i about the spin axis, kg m^2, > 0 */
  double shaft_stiffness[2]; /* k_i of the shaft to the far end, N m/rad, >= 0 (0 = no shaft) */
  double shaft_damping[2];   /* c_i, N m s/rad, >= 0 */
  double tolerance;          /* local error of r_b,i phi_i per internal step, m, > 0 */
  double max_step;           /* largest internal step, s */
  double min_step;           /* smallest internal step before the step fails, s */
  int order_cycles;          /* mesh cycles the orders average over, 1 ... GM_ORDER_CYCLES_MAX */
  int mesh_orders;           /* mesh orders computed, 3 ... GM_MESH_ORDERS_MAX */
} gm_dynamics_params;

typedef struct gm_dynamics_inputs {
  double torque[2];      /* external torque on gear i about its spin axis (+z), N m */
  double shaft_phi[2];   /* far end of gear i's shaft at the start of the step, rad */
  double shaft_omega[2]; /* its speed, held over the step, rad/s */
} gm_dynamics_inputs;

/* What happened over the last gm_dynamics_advance, for a master that steps much longer than the
 * mesh period: the means are impulses over the step's duration, integrated with the method's own
 * weights over the stage points of every internal step, so that J_i (omega_i(end) - omega_i(start))
 * = duration (torque_i + mz_mean_i + shaft_torque_mean_i) holds for each gear (momentum); the TE's
 * extremes are over the stage points. After gm_dynamics_start: the state's values. */
typedef struct gm_step_aggregates {
  double duration;              /* s */
  double force_mean[2][3];      /* mean contact force on gear i, in H, N */
  double moment_mean[2][3];     /* mean contact moment on gear i about its centre, in H, N m */
  double shaft_torque_mean[2];  /* mean torque of each shaft on its gear, N m */
  double normal_force_mean;     /* N */
  double te_mean, te_rms;       /* m */
  double te_min, te_max;        /* m, over the stage points */
} gm_step_aggregates;

/* The aggregates of a step that is one evaluation r (shaft torques: NULL for none): its values. */
void gm_point_aggregates(const gm_result* r, const double* shaft_torque, gm_step_aggregates* out);

/* Mesh orders 1..gm_dynamics_params.mesh_orders of the TE and the normal force in the large-step mode,
 * synchronous with the mesh angle u = z_1 |phi_1| (one mesh cycle per base pitch of gear 1):
 * Fourier coefficients over whole mesh cycles of the integrated trajectory (piecewise linear in u
 * between the stage points, integrated exactly), averaged over the last `cycles` of them, so that
 * signal = mean + sum_k amplitude_k cos(k u + phase_k). Exact for a steady run; in a run-up each
 * cycle has its own speed and the window averages them. A reversal of gear 1 starts the window
 * anew (docs/dynamics.md, "Mesh orders"). */
#define GM_MESH_ORDERS_MAX 12 /* dynamics.mesh_orders' upper bound */
#define GM_ORDER_CYCLES_MAX 16
typedef struct gm_mesh_orders {
  int cycles;                                /* whole mesh cycles in the window (0: none yet) */
  int orders;                                /* orders computed (1 ... orders); those past it are 0 */
  double te_amplitude[GM_MESH_ORDERS_MAX];   /* m */
  double te_phase[GM_MESH_ORDERS_MAX];       /* rad */
  double force_amplitude[GM_MESH_ORDERS_MAX]; /* N */
  double force_phase[GM_MESH_ORDERS_MAX];    /* rad */
  /* the accumulation (internal): the open cycle, its direction, the completed cycles' coefficients */
  int direction;                             /* +1, -1, 0: none yet */
  int open;                                  /* 1 if a cycle began at a boundary and is open */
  double open_from;                          /* u where it began, rad */
  double sums[2][GM_MESH_ORDERS_MAX][2];     /* [te, force][order - 1][cos, sin] of the open cycle */
  double ring[GM_ORDER_CYCLES_MAX][2][GM_MESH_ORDERS_MAX][2];
  int ring_count, ring_next;
} gm_mesh_orders;

typedef struct gm_dynamics_state {
  double phi[2], omega[2]; /* spin state, rad, rad/s */
  double shaft_torque[2];  /* torque of each shaft on its gear at the state, N m */
  double kinetic;          /* sum J_i omega_i^2/2, J */
  double elastic;          /* mesh elastic energy + shaft springs, J */
  double work_in;          /* cumulative work put in by the torques and the shafts' far ends (and
                              by inputs that jump between steps: the elastic energy they change), J */
  double work_out;         /* cumulative work taken out by them (a brake, a load), J */
  double friction;         /* cumulative friction loss, J */
  double damping;          /* cumulative loss in the contact and shaft dampers, J */
  double parametric;       /* cumulative work of the contact forces beyond the change of the mesh's
                              elastic energy, friction and damping: the element's non-conservative
                              part, from a compliance that varies along the path, J */
  double residual;         /* integration error: work_in - work_out - (kinetic + elastic -
                              initial_energy) - friction - damping - parametric, J */
  double initial_energy;   /* kinetic + elastic at gm_dynamics_start, J */
  double step;             /* internal step to try first, s */
  int steps;               /* internal steps accepted by the last gm_dynamics_advance */
  int rejected;            /* internal steps rejected by it (error, Newton, events) */
  gm_step_aggregates step_aggregates; /* over the last gm_dynamics_advance */
  gm_mesh_orders orders;               /* over the last gm_dynamics_params.order_cycles mesh cycles */
} gm_dynamics_state;

/* Defaults: J = 0.02 kg m^2, no shafts, tolerance 1e-8 m, steps 1e-9 ... 1e-3 s, orders over 4
 * mesh cycles. */
void gm_dynamics_default_params(gm_dynamics_params* p);
/* GM_OK, or GM_ERR_PARAMETER with msg naming the parameter and its allowed range (also when m is
 * in quasi-static mode, which the dynamics replace). */
gm_status gm_dynamics_check(const gm_model* m, const gm_dynamics_params* p, char* msg, size_t msg_size);
/* The state at the spins pose->phi, pose->omega: energies zeroed, res the evaluation there. */
gm_status gm_dynamics_start(const gm_model* m, gm_data* d, const gm_dynamics_params* p,
                            const gm_kinematics* pose, const gm_dynamics_inputs* in,
                            gm_dynamics_state* s, gm_result* res);
/* Most internal steps (accepted and rejected) one gm_dynamics_advance takes: a duration of more
 * than this many max_step, or a step that needs more, is GM_ERR_SOLVER (retry shorter). */
#define GM_DYNAMICS_MAX_INTERNAL_STEPS 100000

/* Advance s by duration > 0 with the inputs held (pose: every field but phi and omega, which
 * come from s). res: the evaluation at the end. On error s and res are unchanged and
 * gm_data_message(d) says why: GM_ERR_INPUT for a bad input, GM_ERR_SOLVER when the internal
 * step fell below min_step or the duration needs more than GM_DYNAMICS_MAX_INTERNAL_STEPS
 * internal steps (the caller may retry with a shorter duration). */
gm_status gm_dynamics_advance(const gm_model* m, gm_data* d, const gm_dynamics_params* p,
                              const gm_kinematics* pose, const gm_dynamics_inputs* in, double duration,
                              gm_dynamics_state* s, gm_result* res);

/* The sensitivities of one gm_dynamics_advance's end state to what the step started from: the
 * spins at its start and the inputs held over it (columns GM_SENS_*). Exact for the integrator's
 * own steps: the derivative of the TR-BDF2 stage equations as solved (each stage taken as
 * converged), along the internal step sizes the step chose (held, as internal numerical
 * differentiation holds them). For a master that couples implicitly, with the outputs' partials
 * at the communication point (gm_directional_derivative at the end state) by the chain rule; the
 * shaft's torque at the end is k (shaft_phi + shaft_omega duration - phi) + c (shaft_omega - omega). */
/* the columns: the spin state at the start, then gm_dynamics_inputs' torque, shaft_phi, shaft_omega */
enum {
  GM_SENS_PHI1,
  GM_SENS_PHI2,
  GM_SENS_OMEGA1,
  GM_SENS_OMEGA2,
  GM_SENS_TORQUE1,
  GM_SENS_TORQUE2,
  GM_SENS_SHAFT_PHI1,
  GM_SENS_SHAFT_PHI2,
  GM_SENS_SHAFT_OMEGA1,
  GM_SENS_SHAFT_OMEGA2,
  GM_SENS_COLUMNS
};
typedef struct gm_step_sensitivity {
  double phi[2][GM_SENS_COLUMNS];   /* d phi_i(end) / d column, rad per column unit */
  double omega[2][GM_SENS_COLUMNS]; /* d omega_i(end) / d column, rad/s per column unit */
} gm_step_sensitivity;

/* Where one accepted internal step of a gm_dynamics_advance ends: for a caller that records the
 * mesh signal at the internal steps while stepping far longer (an FMI 3.0 intermediate update). */
typedef struct gm_internal_point {
  double time;            /* s into the call */
  double phi[2], omega[2]; /* the spins there, rad, rad/s */
  double shaft_torque[2]; /* N m */
  const gm_result* res;   /* the evaluation there (valid during the call only) */
} gm_internal_point;
typedef void (*gm_internal_observer)(void* context, const gm_internal_point* point);

/* What a gm_dynamics_advance_with does beyond gm_dynamics_advance (each member NULL: nothing). */
typedef struct gm_advance_options {
  /* the step's sensitivity, written on GM_OK; costs two Jacobians of the mesh (two to four
   * gm_directional_derivative each) per accepted internal step */
  gm_step_sensitivity* sensitivity;
  /* called after each accepted internal step, in order, the last at the step's end; an advance
   * that fails afterwards (GM_ERR_SOLVER) has called it for steps it then takes back */
  gm_internal_observer observer;
  void* observer_context;
} gm_advance_options;

/* gm_dynamics_advance with the options (NULL: none, the same as gm_dynamics_advance). */
gm_status gm_dynamics_advance_with(const gm_model* m, gm_data* d, const gm_dynamics_params* p,
                                   const gm_kinematics* pose, const gm_dynamics_inputs* in, double duration,
                                   gm_dynamics_state* s, gm_result* res, const gm_advance_options* options);

/* Mesh damping by its damping ratio (docs/dynamics.md, "Mesh damping"). The FMU's large-step mode
 * adds to model.damping what dynamics.mesh_damping_ratio (default GM_MESH_DAMPING_RATIO) gives;
 * a C API caller builds its model with that damping the same way. */
#define GM_MESH_DAMPING_RATIO 0.05
/* *damping: the contact damping (model.damping, N s/m^2) that gives the mesh mode of the pair p
 * with gear inertias inertia[2] (kg m^2) the damping ratio `ratio`, on the element's own mean mesh
 * stiffness and contact over a base pitch at ISO 6336-1's reference line load (100 N/mm). Builds
 * a probe model of p (at level 5 it reads the databases). 0 for ratio 0. Errors: a parameter out
 * of range (GM_ERR_PARAMETER, msg names it), or what gm_model_create says of p. */
gm_status gm_mesh_damping_for_ratio(const gm_model_params* p, const double inertia[2], double ratio,
                                    double* damping, char* msg, size_t msg_size);

/* The load distribution across the face (docs/model.md, "Load across the face"). */
/* One loaded tooth pair of the last gm_evaluate. */
typedef struct gm_pair_load {
  double force;         /* its normal force, N (the sum of its slices') */
  double share;         /* its share of the mesh's normal force, 0..1 */
  double path_position; /* where it is on the path of contact: 0 at the start, 1 at the end (the
                           mean over its loaded slices, weighted by their forces) */
  double approach;      /* the largest normal approach of its loaded slices, m */
  int flank;            /* 1 flank A, 2 flank B */
} gm_pair_load;

/* The tooth pairs that the last gm_evaluate of d loaded, in the order of their position on the
 * path of contact (flank A's, then flank B's), and the line load of each at the model's
 * gm_model_parameters(m)->slices slices across the axial overlap: line_load[k * slices + j], N/m,
 * 0 where the pair's slice j carries nothing. Writes max_pairs rows of pairs and line_load (rows
 * past the loaded pairs are zero; either pointer may be NULL) and returns how many tooth pairs are
 * loaded, which may exceed max_pairs: then only the first max_pairs are written. 0 before the
 * first evaluation and after a failed one. */
int gm_data_load_distribution(const gm_model* m, const gm_data* d, int max_pairs, gm_pair_load* pairs,
                              double* line_load);

/* The centre of each of the model's slices across the axial overlap at the nominal pose, as a
 * coordinate along the housing frame's z axis, m (z[j], j < gm_model_parameters(m)->slices). */
void gm_model_slice_positions(const gm_model* m, double* z);

/* Last error message of d ("" if none). */
const char* gm_data_message(const gm_data* d);

/* Version string of the core, e.g. "0.1.0". */
const char* gm_version(void);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_H */
