/* The model behind the generic FMI 2.0 layer (Reference-FMUs layering): fmi2_functions.c knows
 * FMI (state machine, logging, time, FMU state framing); model_gearmesh.c holds the variable
 * values and reaches the physics only through the core's C API. Errors come back as a nonzero
 * return and a message in the caller's buffer. */
#ifndef GEARMESH_FMU_MODEL_H
#define GEARMESH_FMU_MODEL_H

#include <stddef.h>

#include "variables.h"

typedef struct fmu_model fmu_model;

/* Log hook into the generic layer, which drops messages of disabled categories. */
typedef void (*fmu_log_fn)(void* context, gm_log_category category, const char* format, ...);

/* The variable with value reference vr, or NULL if there is none. */
const gm_fmu_variable* model_variable(unsigned vr);

/* A model at the generic start values (the core's defaults); NULL if out of memory. */
fmu_model* model_new(fmu_log_fn log, void* log_context);
void model_free(fmu_model* m);
/* The FMU's local resources directory (ending in '/'; NULL if the importer gave none), once,
 * before anything else: file names in String parameters are resolved against it, and a scene
 * FMU's start values (values.h, FMU_START_VALUES_FILE) are read from it and become the start
 * values. Nonzero on error (a malformed start values file), with msg. */
int model_set_resources(fmu_model* m, const char* resources, char* msg, size_t msg_size);
/* Back to the start values; the core model is dropped. Nonzero if out of memory. */
int model_reset(fmu_model* m);

/* Values of v (Integer and Boolean are int; a String is never NULL and stays valid until it is
 * set again or the model is reset or freed). Setting a parameter or input to another value marks
 * the outputs stale; setting a parameter also the core model (the value it holds: nothing
 * changes). model_set_string takes over a malloc'd copy. */
double model_get_real(const fmu_model* m, const gm_fmu_variable* v);
int model_get_int(const fmu_model* m, const gm_fmu_variable* v);
const char* model_get_string(const fmu_model* m, const gm_fmu_variable* v);
void model_set_real(fmu_model* m, const gm_fmu_variable* v, double x);
void model_set_int(fmu_model* m, const gm_fmu_variable* v, int x);
void model_set_string(fmu_model* m, const gm_fmu_variable* v, char* owned);

/* (Re)build the core model if the parameters changed since the last build. */
int model_build(fmu_model* m, char* msg, size_t msg_size);
/* Evaluate the contact at the held inputs and publish the outputs (time only labels log
 * messages). restart forgets warm start and friction memory first. With model.dynamics = 1,
 * restart starts the spin state from the inputs gear<i>.phi/.omega and otherwise the spins are
 * integrated over step (s). Returns 0, 1 on error, or 2 (nothing changed, msg set) if the
 * large-step integration failed (a shorter step may succeed) or if, without restart and with
 * prescribed spins, the TE would jump by half a base pitch or more from the last evaluation's
 * (a skipped tooth). */
int model_evaluate(fmu_model* m, int restart, double time, double step, char* msg, size_t msg_size);
/* The outputs at the current inputs at a communication point, time not advanced: a read after
 * inputs were set since the last evaluation (the direct feedthrough that modelDescription.xml
 * declares, docs/fmi.md "Feedthrough"). The contact is evaluated on scratch memory loaded with
 * the last evaluation's, so what the next model_evaluate computes does not change; with
 * model.dynamics = 1 at the spin state, which stays as the last step left it. Nonzero on error,
 * with msg. */
int model_feedthrough(fmu_model* m, double time, char* msg, size_t msg_size);
/* Directional derivative of the outputs (out->y, and the spin outputs out->ds) along the input
 * direction seed (gm_directional_derivative on seed->k) at the current inputs, to which the
 * outputs read belong. Nonzero on error, with msg (also with model.dynamics = 1, which has no
 * derivatives in this version). */
int model_directional_derivative(fmu_model* m, const gm_fmu_values* seed, gm_fmu_values* out, char* msg,
                                 size_t msg_size);
/* Design warnings of the built core model ("" if none or not built). */
const char* model_warnings(const fmu_model* m);
/* 1 if the outputs belong to the current parameters and inputs. */
int model_outputs_current(const fmu_model* m);

/* Model part of the FMU state: every parameter, input and output (values.h), plus the core's
 * blob. */
size_t model_state_size(const fmu_model* m);
void model_state_save(const fmu_model* m, unsigned char* buf); /* writes model_state_size bytes */
int model_state_load(fmu_model* m, const unsigned char* buf, size_t size, char* msg, size_t msg_size);

#endif /* GEARMESH_FMU_MODEL_H */
