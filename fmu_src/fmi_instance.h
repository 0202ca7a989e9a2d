/* What the generic FMI 2.0 and FMI 3.0 co-simulation layers (fmi2_functions.c, fmi3_functions.c)
 * share: an instance's life, its log, the call sequence, values, FMU states, directional
 * derivatives and the step, over model.h and nothing else of the model. Each layer maps its
 * standard's functions and types onto these; what differs between the standards (the logger's
 * signature, how the resources are named, the step's extra results, the Boolean's size) stays in
 * the layer. No mutable globals: everything lives in the instance, so instances run in parallel
 * threads. */
#ifndef FMU_FMI_INSTANCE_H
#define FMU_FMI_INSTANCE_H

#include <stdarg.h>
#include <stddef.h>

#include "model.h"

/* The status codes, numbered as fmi2Status and fmi3Status both number them. */
typedef enum { FMI_OK = 0,
               FMI_WARNING = 1,
               FMI_DISCARD = 2,
               FMI_ERROR = 3,
               FMI_FATAL = 4 } fmi_status;

/* The layer's logger: one finished message (valid UTF-8, no format conversions left). */
typedef void (*fmi_logger)(void* environment, const char* instance_name, fmi_status status, const char* category,
                           const char* message);

/* The co-simulation modes this FMU can be in (both standards; the step is synchronous, so no
 * pending, failed or cancelled step; no event mode). */
typedef enum {
  FMI_INSTANTIATED = 1,
  FMI_INITIALIZATION = 2,
  FMI_STEP = 4, /* FMI 2.0 stepComplete, FMI 3.0 Step Mode */
  FMI_TERMINATED = 8,
  FMI_ERROR_MODE = 16,
  FMI_CONFIGURATION = 32 /* FMI 3.0 Configuration Mode: the structural parameters are set */
} fmi_mode;

#define FMI_ANY_MODE \
  (FMI_INSTANTIATED | FMI_INITIALIZATION | FMI_STEP | FMI_TERMINATED | FMI_ERROR_MODE | FMI_CONFIGURATION)
#define FMI_MASK_SET_VALUES (FMI_INSTANTIATED | FMI_INITIALIZATION | FMI_STEP)
#define FMI_MASK_GET_VALUES (FMI_INITIALIZATION | FMI_STEP | FMI_TERMINATED)
#define FMI_MASK_GET_STATE (FMI_INSTANTIATED | FMI_INITIALIZATION | FMI_STEP | FMI_TERMINATED)
#define FMI_MASK_STATUS (FMI_STEP | FMI_TERMINATED | FMI_ERROR_MODE)

/* How the standard spells what messages name. */
typedef struct fmi_api {
  const char* prefix;     /* "fmi2" */
  const char* standard;   /* "FMI 2.0" */
  const char* state;      /* "FMUstate" (2.0) or "FMUState" (3.0) */
  const char* step_mode;  /* the name of FMI_STEP: "stepComplete", "Step Mode" */
  const char* last_time;  /* where the master reads the last successful time */
} fmi_api;

typedef struct fmi_instance {
  const fmi_api* api;
  fmi_logger logger;
  void* environment; /* passed back to the logger unchanged */
  char* name;        /* own copy: the importer's string is valid only during the call */
  char* resources;   /* local resources directory ending in '/', or NULL */
  unsigned categories; /* enabled log categories, bit i = category i (model.h) */
  fmi_mode mode;
  double time; /* start time, then the end of the last successful step */
  int stop_defined;
  double stop_time;
  fmu_model* model;
  void** states;   /* the FMU states this instance made and has not freed: no other pointer is */
  size_t n_states; /* taken for one (an importer's stale or uninitialised pointer is refused) */
  size_t cap_states;
  char msg[1024]; /* message from the model layer (may hold a path in resources/) */
  /* the last step was discarded and nothing has changed since (cleared by a step taken, a value
   * set to another value, setting an FMU state, a reset): its start, length and reason */
  int discarded;
  double discarded_tc, discarded_h;
  char discarded_msg[1024];
} fmi_instance;

/* ---- logging ---------------------------------------------------------------------------- */

void fmi_log_event(const fmi_instance* c, const char* format, ...);
fmi_status fmi_error(const fmi_instance* c, const char* format, ...);
void fmi_warning(const fmi_instance* c, const char* format, ...);
fmi_status fmi_discard(const fmi_instance* c, const char* format, ...);

/* ---- life ------------------------------------------------------------------------------- */

/* A new instance (every log category on if logging_on), its model reading resources (a local
 * directory ending in '/', which the instance takes over, or NULL; resources_warning, if not
 * NULL, is logged as a warning once the instance exists). `probe` holds the logger,
 * environment, api and a name for messages while refusing. NULL on failure (logged). */
fmi_instance* fmi_instantiate(const char* function, const fmi_instance* probe, const char* instance_name,
                              int logging_on, char* resources, const char* resources_warning);
void fmi_free(fmi_instance* c);
/* 1 (logged) if c is NULL or not in one of the allowed modes. */
int fmi_illegal(const fmi_instance* c, const char* function, unsigned allowed);

fmi_status fmi_set_debug_logging(fmi_instance* c, const char* function, int logging_on, size_t n,
                                 const char* const categories[]);
/* Start and stop time (FMI 2.0 fmi2SetupExperiment, FMI 3.0 fmi3EnterInitializationMode). */
fmi_status fmi_setup(fmi_instance* c, const char* function, double start, int stop_defined, double stop);
fmi_status fmi_enter_initialization(fmi_instance* c, const char* function);
fmi_status fmi_exit_initialization(fmi_instance* c, const char* function);
fmi_status fmi_terminate(fmi_instance* c, const char* function);
fmi_status fmi_reset(fmi_instance* c, const char* function);

/* ---- values ----------------------------------------------------------------------------- */

/* Values of `type` into or from `values`, an array of double (Real), int (Integer), char*
 * (String) or, for Boolean, of bool_size-byte integers (FMI 2.0: int; FMI 3.0: bool). A refused
 * set changes nothing; the instance owns a copy of every string it is given. */
fmi_status fmi_get_values(fmi_instance* c, const char* function, model_type type, const unsigned vr[], size_t nvr,
                          void* values, size_t bool_size);
fmi_status fmi_set_values(fmi_instance* c, const char* function, model_type type, const unsigned vr[], size_t nvr,
                          const void* values, size_t bool_size);

/* ---- FMU state -------------------------------------------------------------------------- */

fmi_status fmi_get_state(fmi_instance* c, const char* function, void** state);
fmi_status fmi_set_state(fmi_instance* c, const char* function, void* state);
fmi_status fmi_free_state(fmi_instance* c, const char* function, void** state);
fmi_status fmi_state_size(fmi_instance* c, const char* function, void* state, size_t* size);
fmi_status fmi_serialize_state(fmi_instance* c, const char* function, void* state, unsigned char* buffer,
                               size_t size);
fmi_status fmi_deserialize_state(fmi_instance* c, const char* function, const unsigned char* buffer, size_t size,
                                 void** state);

/* ---- derivatives and the step ----------------------------------------------------------- */

/* d(outputs)/d(inputs) . seed (model_directional_derivative), at the current inputs, to which the
 * outputs read belong (docs/fmi.md, "Feedthrough"): knowns Real inputs with finite seeds,
 * unknowns Real outputs. The instance's state is not changed. */
fmi_status fmi_directional_derivative(fmi_instance* c, const char* function, const unsigned unknown[],
                                      size_t n_unknown, const unsigned known[], size_t n_known, const double seed[],
                                      double sensitivity[]);

/* One communication step from tc by h (inputs held, outputs at tc + h): FMI_OK, FMI_DISCARD
 * (nothing changed, the reason logged) or FMI_ERROR (the Error mode after a failed evaluation). */
fmi_status fmi_do_step(fmi_instance* c, const char* function, double tc, double h);

#endif /* FMU_FMI_INSTANCE_H */
