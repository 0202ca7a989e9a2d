/* The model behind the generic FMI 2.0 co-simulation layer (Reference-FMUs layering).
 * fmi2_functions.c knows FMI (state machine, logging, time, FMU state framing) and reaches the
 * model only through this header, whose types are model-neutral: value references, C types of
 * the fmi2 values (double; int for Integer and Boolean; char strings), an opaque model and a
 * variable-info accessor. A model implements it; GearMesh's is model_gearmesh.c. Errors come
 * back as a nonzero return and a message in the caller's buffer. */
#ifndef FMU_MODEL_H
#define FMU_MODEL_H

#include <stddef.h>

typedef struct fmu_model fmu_model;

/* ---- identity and variables ------------------------------------------------------------- */

/* modelIdentifier (an FMU state starts with its first 8 bytes, NUL-padded) and the GUID of this
 * build, which fmi2Instantiate and every FMU state check; at most MODEL_GUID_SIZE - 1 chars. */
extern const char model_identifier[];
extern const char model_guid[];
#define MODEL_GUID_SIZE 40

/* The FMI attributes of a variable, spelled as in modelDescription.xml. */
typedef enum { MODEL_Real, MODEL_Integer, MODEL_Boolean, MODEL_String } model_type;
typedef enum { MODEL_parameter, MODEL_calculatedParameter, MODEL_input, MODEL_output } model_causality;
typedef enum { MODEL_fixed, MODEL_tunable, MODEL_discrete, MODEL_continuous } model_variability;

typedef struct model_variable_info {
  const char* name;
  model_type type;
  model_causality causality;
  model_variability variability;
} model_variable_info;

/* The variable with value reference vr, or NULL if there is none. */
const model_variable_info* model_variable(unsigned vr);
/* How many there are: value references 0 .. count - 1 (the FMI 3.0 layer's independent variable
 * `time` takes the next). */
unsigned model_variable_count(void);
/* 1 if vr may be read during an intermediate result (model_set_intermediate). */
int model_variable_intermediate(unsigned vr);

/* 1 if vr is a structural parameter (an Integer parameter that arrays' dimensions name; FMI 3.0
 * declares it UInt64 causality="structuralParameter"). */
int model_variable_structural(unsigned vr);

/* ---- arrays ----------------------------------------------------------------------------- */

/* Real arrays: FMI 3.0 array variables, value references model_variable_count() + 1 + a (after
 * `time`). Each element is also a Real scalar with value reference MODEL_ELEMENT_VR(a, i), i its
 * index in row-major order, which model_variable describes (the array's info) and
 * model_get_real reads: FMI 2.0, which has no arrays, reaches the elements so (a scene FMU lists
 * the ones it needs). */
#define MODEL_ELEMENT_VR_BASE 0x40000000u
#define MODEL_ELEMENT_VR(a, i) (MODEL_ELEMENT_VR_BASE + ((unsigned)(a) << 20) + (unsigned)(i))
#define MODEL_ELEMENT_ARRAY(vr) (((vr) - MODEL_ELEMENT_VR_BASE) >> 20)
#define MODEL_ELEMENT_INDEX(vr) (((vr) - MODEL_ELEMENT_VR_BASE) & 0xFFFFFu)
unsigned model_array_count(void);
/* The elements array a has now (its dimensions' product at the current structural parameters). */
size_t model_array_length(const fmu_model* m, unsigned a);

/* ---- logging ---------------------------------------------------------------------------- */

/* Log categories are numbered as in modelDescription.xml's <LogCategories>: first the generic
 * layer's five, with FMI's standard names, then the model's own (at most 32 in all). */
enum { MODEL_LOG_EVENTS, MODEL_LOG_WARNING, MODEL_LOG_ERROR, MODEL_LOG_FATAL, MODEL_LOG_ALL };
unsigned model_log_category_count(void);
const char* model_log_category_name(unsigned category);

/* Log hook into the generic layer, which drops messages of disabled categories. */
typedef void (*fmu_log_fn)(void* context, unsigned category, const char* format, ...);

/* ---- lifetime --------------------------------------------------------------------------- */

/* A model at its start values; NULL if out of memory. */
fmu_model* model_new(fmu_log_fn log, void* log_context);
void model_free(fmu_model* m);
/* The FMU's local resources directory (ending in '/'; NULL if the importer gave none), once,
 * before anything else: the model may read its data and start values from there. Nonzero on
 * error, with msg. */
int model_set_resources(fmu_model* m, const char* resources, char* msg, size_t msg_size);
/* Back to the start values. Nonzero if out of memory. */
int model_reset(fmu_model* m);

/* ---- values ----------------------------------------------------------------------------- */

/* Values of the variable with value reference vr, which the caller has checked with
 * model_variable (Integer and Boolean are int; a String is never NULL and stays valid until it
 * is set again or the model is reset or freed). Setting a parameter or input to another value
 * marks the outputs stale (the value it holds: nothing changes). model_set_string takes over a
 * malloc'd copy. */
double model_get_real(const fmu_model* m, unsigned vr);
int model_get_int(const fmu_model* m, unsigned vr);
const char* model_get_string(const fmu_model* m, unsigned vr);
void model_set_real(fmu_model* m, unsigned vr, double x);
void model_set_int(fmu_model* m, unsigned vr, int x);
void model_set_string(fmu_model* m, unsigned vr, char* owned);

/* ---- evaluation ------------------------------------------------------------------------- */

/* Bring the calculated parameters up to date with the parameters. Nonzero on error, with msg. */
int model_build(fmu_model* m, char* msg, size_t msg_size);
/* Whether model_build and the first evaluation would refuse the parameters and the inputs as far as
 * that is known without reading a file or building the model (a model without a cheaper check:
 * model_build itself). 0, or nonzero with the message they would give. */
int model_check(fmu_model* m, char* msg, size_t msg_size);
/* Compute the outputs at the held inputs (time only labels log messages): restart (Initialization
 * Mode, its end) starts from the inputs and forgets any memory of earlier evaluations; otherwise
 * a communication step of step (s) ending at time. Returns 0, 1 on error, or 2 (nothing changed,
 * msg set) for a step the model refuses but a shorter one or another input may pass
 * (fmi2Discard). */
int model_evaluate(fmu_model* m, int restart, double time, double step, char* msg, size_t msg_size);
/* The outputs at the current inputs at a communication point, time not advanced: a read after
 * inputs were set since the last evaluation (the direct feedthrough that modelDescription.xml
 * declares). What the next model_evaluate computes does not change. Nonzero on error, with msg. */
int model_feedthrough(fmu_model* m, double time, char* msg, size_t msg_size);
/* 1 if the outputs belong to the current parameters and inputs. */
int model_outputs_current(const fmu_model* m);
/* Directional derivative at the current inputs, to which the outputs read belong:
 * dv_unknown[j] = sum_i d(unknown[j])/d(known[i]) dv_known[i], the knowns Real inputs and the
 * unknowns Real outputs (the caller has checked both; a known listed twice adds up). What the
 * next model_evaluate computes does not change. Nonzero on error, with msg. */
int model_directional_derivative(fmu_model* m, const unsigned known[], const double dv_known[], size_t n_known,
                                 const unsigned unknown[], double dv_unknown[], size_t n_unknown, char* msg,
                                 size_t msg_size);
/* Results inside a step: fn(context, time) after each internal step of a model_evaluate that
 * integrates (GearMesh's large-step mode), the outputs flagged for intermediate access then those
 * at that time (read through the getters during fn); the step's end outputs follow when
 * model_evaluate returns, and a step that fails takes them back. NULL: none (the default). */
typedef void (*model_intermediate_fn)(void* context, double time);
void model_set_intermediate(fmu_model* m, model_intermediate_fn fn, void* context);
/* Warnings about the model built from the parameters ("" if none or not built). */
const char* model_warnings(const fmu_model* m);

/* ---- FMU state -------------------------------------------------------------------------- */

/* The model's part of an FMU state: self-contained bytes in native byte order. */
size_t model_state_size(const fmu_model* m);
void model_state_save(const fmu_model* m, unsigned char* buf); /* writes model_state_size bytes */
/* Nonzero with msg if buf is not a state of this model; m is then unchanged. */
int model_state_load(fmu_model* m, const unsigned char* buf, size_t size, char* msg, size_t msg_size);

#endif /* FMU_MODEL_H */
