/* Gear trains through the C API (core/src/train.hpp: the model, its equations and what a
 * torsional train neglects). Bodies turn about parallel axes; shafts join two bodies or a body
 * and a far end (a port: angle and speed in); meshes are GearMesh elements (each its own
 * gm_model, which the caller keeps alive) between two bodies, on the housing or on a carrier.
 * Indices count from 0; -1 means the housing (a mesh's carrier) or a far end (a shaft's other
 * end). The train's spins are integrated as the pair's large-step mode integrates its two gears
 * (gm_dynamics_advance). */
#ifndef GEARMESH_TRAIN_H
#define GEARMESH_TRAIN_H

#include <stddef.h>

#include "gearmesh/gearmesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct gm_train gm_train;

typedef struct gm_train_body {
  double inertia; /* kg m^2 about its axis, > 0 unless fixed */
  int fixed;      /* held at angle 0 (a ring in the housing); its holding torque is reported */
  double mass;    /* kg; > 0: the centre translates in the housing's plane on its bearing (a body on
                     the housing's axis carrying no mesh: a sun, a ring); 0: it does not */
  double bearing_stiffness, bearing_damping; /* N/m, N s/m per axis; 0 and 0 with a mass: floating */
  double pin_error[2]; /* a planet's centre off its place in the carrier, tangential (along the
                          carrier's turning) and radial (outwards), m */
} gm_train_body;

typedef struct gm_train_mesh {
  const gm_model* model; /* the element; the train makes its own gm_data for it */
  int gear[2];           /* bodies of the element's gear 1 and gear 2 */
  int carrier;           /* body carrying the mesh, -1: the housing */
  double orientation;    /* rad: direction from the element's gear 1 to its gear 2, in the carrier's frame */
} gm_train_mesh;

typedef struct gm_train_shaft {
  int body;                 /* the body the shaft turns */
  int other;                /* the body at its other end, -1: a far end (port) */
  double stiffness, damping; /* N m/rad, N m s/rad, >= 0 */
} gm_train_shaft;

typedef struct gm_train_energy {
  double kinetic, elastic, initial; /* J */
  double work_in, work_out, friction, damping, parametric, residual; /* J, cumulative (gm_dynamics_state) */
} gm_train_energy;

/* A train; GM_ERR_PARAMETER with msg naming what is wrong (an index out of range, a body
 * without inertia, a body in no mesh and on no shaft, an integrator setting out of range). */
gm_status gm_train_create(const gm_train_body* bodies, int body_count, const gm_train_mesh* meshes, int mesh_count,
                          const gm_train_shaft* shafts, int shaft_count, double tolerance, double max_step,
                          double min_step, gm_train** out, char* msg, size_t msg_size);
void gm_train_free(gm_train* t);

/* The state at phi, omega (one per body; fixed bodies 0) with the inputs: torque per body (N m
 * about +z, held over a step), far_phi and far_omega per shaft (read where the shaft's other end
 * is -1; NULL if there are no shafts). Energies zeroed. */
gm_status gm_train_start(gm_train* t, const double* phi, const double* omega, const double* torque,
                         const double* far_phi, const double* far_omega);
/* Advance by duration with the inputs held (the far ends move on at far_omega). On an error the
 * state is unchanged and gm_train_message says why (GM_ERR_SOLVER: retry shorter). */
gm_status gm_train_advance(gm_train* t, const double* torque, const double* far_phi, const double* far_omega,
                           double duration);

/* The static equilibrium (the quasi-static train): body `held` at held_angle, every other free
 * body's torque (and translating body's force) balanced, speeds zero, the torques applied and
 * the far ends held at far_phi; phi (one per body) is the start of the search (NULL: the current
 * state's angles). It becomes the state (at rest, energies zeroed), the held body's holding
 * torque its output. GM_ERR_SOLVER (state unchanged) if no equilibrium is found. */
gm_status gm_train_static(gm_train* t, int held, double held_angle, const double* phi, const double* torque,
                          const double* far_phi);

/* The state after the last start, advance or static solve. */
gm_status gm_train_body_state(const gm_train* t, int body, double* phi, double* omega, double* holding_torque);
/* A translating body's centre in the housing, m (0, 0 for the others). */
gm_status gm_train_body_centre(const gm_train* t, int body, double* x, double* y);
gm_status gm_train_shaft_torque(const gm_train* t, int shaft, double* torque); /* on its body, N m */
const gm_result* gm_train_mesh_result(const gm_train* t, int mesh);          /* NULL if out of range */
gm_train_energy gm_train_energy_account(const gm_train* t);
/* Internal steps accepted and rejected by the last advance. */
void gm_train_steps(const gm_train* t, int* accepted, int* rejected);
/* The work of the last advance: evaluations of the whole train (each evaluates every mesh once)
 * and directional derivatives of single meshes (the Jacobian's columns). */
void gm_train_work(const gm_train* t, long* evaluations, long* derivatives);
const char* gm_train_message(const gm_train* t);

/* The train's state (spins, energies, the next internal step and each mesh's evaluation memory)
 * as bytes, for FMU state: size, save (exactly size bytes), load (GM_ERR_ARGUMENT if the bytes
 * are not a state of a train of this shape; the train is then unchanged). */
size_t gm_train_state_size(const gm_train* t);
gm_status gm_train_state_save(const gm_train* t, void* buf, size_t size);
gm_status gm_train_state_load(gm_train* t, const void* buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_TRAIN_H */
