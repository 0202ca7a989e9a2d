/* Generic FMI 3.0 co-simulation layer: every fmi3* function, mapped onto the shared instance
 * (fmi_instance.h) and model.h, as fmi2_functions.c maps FMI 2.0's. What FMI 3.0 adds and this
 * FMU does not offer (event mode, clocks, model exchange, scheduled execution, the integer and
 * binary types it has no variables of) is refused with an error naming the function; the
 * modelDescription.xml of --fmi3 declares the same (hasEventMode="false"). Intermediate update:
 * with a callback given at instantiation, the large-step mode calls it after each internal step
 * with the contact, spins and shaft torques readable at that time (intermediateUpdate="true").
 *
 * The variables are the FMI 2.0 table's, with the same value references: Real as Float64,
 * Integer as Int32 (a structural parameter as UInt64), Boolean and String as themselves; plus the
 * independent variable `time` at value reference model_variable_count(), which reads the
 * instance's time, and after it the arrays (model.h), Float64 arrays whose elements come in
 * row-major order: nValues counts them. Configuration Mode sets the structural parameters. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmi_instance.h"
#include "model.h"

_Static_assert((int)fmi3OK == FMI_OK && (int)fmi3Warning == FMI_WARNING && (int)fmi3Discard == FMI_DISCARD &&
                   (int)fmi3Error == FMI_ERROR && (int)fmi3Fatal == FMI_FATAL,
               "fmi3Status numbers the statuses as fmi_status does");
_Static_assert(sizeof(fmi3ValueReference) == sizeof(unsigned) && sizeof(fmi3Int32) == sizeof(int) &&
                   sizeof(fmi3Float64) == sizeof(double) && sizeof(fmi3Boolean) == 1,
               "the fmi3 value types are the C types of model.h (Boolean: one byte)");

static const fmi_api api = {"fmi3", "FMI 3.0", "FMUState", "Step Mode", "lastSuccessfulTime"};

/* The importer's logger behind the shared instance's (FMI 3.0 passes no instance name). */
typedef struct logger_box {
  fmi3LogMessageCallback logger;
  fmi3InstanceEnvironment environment;
} logger_box;

static void fmi3_log(void* environment, const char* name, fmi_status status, const char* category,
                     const char* message) {
  (void)name;
  const logger_box* box = environment;
  box->logger(box->environment, (fmi3Status)status, category, message);
}

typedef struct instance {
  fmi_instance* shared;
  logger_box box;
  fmi3IntermediateUpdateCallback intermediate_update; /* NULL: none */
  fmi3InstanceEnvironment environment;
  int in_intermediate; /* inside the callback: only intermediate variables may be read */
} instance;

/* After each internal step of a step (model_set_intermediate): the importer reads the
 * intermediate variables at that time; it may neither set variables nor return early
 * (providesIntermediateUpdate="true", canReturnEarlyAfterIntermediateUpdate not declared). */
static void intermediate(void* context, double time) {
  instance* outer = context;
  fmi3Boolean early = fmi3False;
  fmi3Float64 early_time = time;
  outer->in_intermediate = 1;
  outer->intermediate_update(outer->environment, time, fmi3False, fmi3True, fmi3True, fmi3False, &early, &early_time);
  outer->in_intermediate = 0;
}

/* Inside an intermediate update only the intermediate variables may be read. */
static int not_intermediate(const instance* outer, const char* function, const fmi3ValueReference vr[], size_t n) {
  if (!outer->in_intermediate) return 0;
  for (size_t i = 0; i < n && vr; i++)
    if (!model_variable_intermediate(vr[i])) {
      fmi_error(outer->shared,
                "%s: value reference %u read during an intermediate update; allowed there: the outputs with "
                "intermediateUpdate=\"true\"",
                function, (unsigned)vr[i]);
      return 1;
    }
  return 0;
}

#define CHECK_MODE(allowed)                                                   \
  instance* outer = (instance*)component;                                    \
  fmi_instance* c = outer ? outer->shared : NULL;                           \
  if (fmi_illegal(c, __func__, (allowed))) return fmi3Error

#define CHECK_POINTER(p)                                                      \
  if (!(p)) return (fmi3Status)fmi_error(c, "%s: argument %s must not be NULL", __func__, #p)

/* An FMI 3.0 function this FMU does not provide: an error naming it (no state change). */
#define UNSUPPORTED(why)                                                        \
  CHECK_MODE(FMI_ANY_MODE);                                                    \
  return (fmi3Status)fmi_error(c, "%s: not supported: %s", __func__, why)

static unsigned time_vr(void) {
  return model_variable_count();
}

/* ---- inquire, log, instantiate ---------------------------------------------------------- */

const char* fmi3GetVersion(void) {
  return fmi3Version;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance component, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_set_debug_logging(c, __func__, loggingOn, nCategories, categories);
}

/* The directory resourcePath names, with one trailing '/', in a malloc'd string (NULL for none). */
static char* resources_directory(const char* path) {
  if (!path || !path[0]) return NULL;
  size_t n = strlen(path);
  char* dir = malloc(n + 2);
  if (!dir) return NULL;
  memcpy(dir, path, n);
  if (dir[n - 1] != '/') dir[n++] = '/';
  dir[n] = '\0';
  return dir;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
  (void)visible, (void)earlyReturnAllowed;
  instance* outer = calloc(1, sizeof *outer);
  logger_box box = {logMessage, instanceEnvironment};
  fmi_instance probe = {.api = &api,
                        .logger = logMessage ? fmi3_log : NULL,
                        .environment = outer ? (void*)&outer->box : (void*)&box,
                        .name = (char*)(instanceName && instanceName[0] ? instanceName : model_identifier)};
  if (!outer) {
    fmi_error(&probe, "fmi3InstantiateCoSimulation: out of memory");
    return NULL;
  }
  outer->box = box;
  const char* refusal = NULL;
  char text[256];
  if (!instanceName || !instanceName[0]) refusal = "instanceName must be a non-empty string";
  else if (!instantiationToken || strcmp(instantiationToken, model_guid) != 0) {
    snprintf(text, sizeof text,
             "instantiationToken %.60s does not match this binary's %s (modelDescription.xml is from another build)",
             instantiationToken ? instantiationToken : "(NULL)", model_guid);
    refusal = text;
  } else if (eventModeUsed)
    refusal = "eventModeUsed = true: this FMU has no event mode (hasEventMode=\"false\")";
  else if (nRequiredIntermediateVariables && !requiredIntermediateVariables)
    refusal = "requiredIntermediateVariables is NULL with nRequiredIntermediateVariables > 0";
  for (size_t i = 0; !refusal && i < nRequiredIntermediateVariables; i++)
    if (!model_variable_intermediate(requiredIntermediateVariables[i])) {
      snprintf(text, sizeof text,
               "requiredIntermediateVariables[%zu] = %u has no intermediate values; allowed: the outputs with "
               "intermediateUpdate=\"true\" (the contact, the spins and the shaft torques)",
               i, (unsigned)requiredIntermediateVariables[i]);
      refusal = text;
    }
  if (refusal) {
    fmi_error(&probe, "fmi3InstantiateCoSimulation: %s", refusal);
    free(outer);
    return NULL;
  }
  outer->shared = fmi_instantiate("fmi3InstantiateCoSimulation", &probe, instanceName, loggingOn,
                                  resources_directory(resourcePath), NULL);
  if (!outer->shared) {
    free(outer);
    return NULL;
  }
  if (intermediateUpdate) {
    outer->intermediate_update = intermediateUpdate;
    outer->environment = instanceEnvironment;
    model_set_intermediate(outer->shared->model, intermediate, outer);
  }
  return outer;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
  (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
  if (logMessage)
    logMessage(instanceEnvironment, fmi3Error, "logStatusError",
               "fmi3InstantiateModelExchange: GearMesh is a co-simulation FMU only");
  (void)instanceName;
  return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
  (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
  (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
  if (logMessage)
    logMessage(instanceEnvironment, fmi3Error, "logStatusError",
               "fmi3InstantiateScheduledExecution: GearMesh is a co-simulation FMU only");
  return NULL;
}

void fmi3FreeInstance(fmi3Instance component) {
  instance* outer = (instance*)component;
  if (!outer) return;
  fmi_free(outer->shared);
  free(outer);
}

/* ---- modes ------------------------------------------------------------------------------ */

fmi3Status fmi3EnterInitializationMode(fmi3Instance component, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  (void)toleranceDefined, (void)tolerance; /* a model's solvers have their own tolerance parameters */
  CHECK_MODE(FMI_INSTANTIATED);
  fmi_status s = fmi_setup(c, __func__, startTime, stopTimeDefined, stopTime);
  return (fmi3Status)(s == FMI_OK ? fmi_enter_initialization(c, __func__) : s);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance component) {
  CHECK_MODE(FMI_INITIALIZATION);
  return (fmi3Status)fmi_exit_initialization(c, __func__);
}

fmi3Status fmi3EnterEventMode(fmi3Instance component) {
  UNSUPPORTED("this FMU has no event mode (hasEventMode=\"false\")");
}

fmi3Status fmi3EnterStepMode(fmi3Instance component) {
  UNSUPPORTED("the instance enters Step Mode at fmi3ExitInitializationMode (no event mode)");
}

fmi3Status fmi3Terminate(fmi3Instance component) {
  CHECK_MODE(FMI_STEP);
  return (fmi3Status)fmi_terminate(c, __func__);
}

fmi3Status fmi3Reset(fmi3Instance component) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_reset(c, __func__);
}

/* ---- values ----------------------------------------------------------------------------- */

/* nValues must be nValueReferences for types without arrays. */
static fmi3Status scalars(fmi_instance* c, const char* function, size_t nvr, size_t n_values) {
  if (n_values == nvr) return fmi3OK;
  return (fmi3Status)fmi_error(c,
                               "%s: nValues = %zu for %zu value references; allowed: equal (no variable of this "
                               "type is an array)",
                               function, n_values, nvr);
}

/* The array with FMI 3.0 value reference vr (after `time`), or -1. */
static int array_of(unsigned vr) {
  const unsigned first = time_vr() + 1;
  return vr >= first && vr - first < model_array_count() ? (int)(vr - first) : -1;
}

/* Structural parameters are UInt64 in FMI 3.0: not Int32 (1 with an error naming the first). */
static int structural_as_int32(fmi_instance* c, const char* function, const fmi3ValueReference vr[], size_t n) {
  for (size_t i = 0; i < n && vr; i++)
    if (model_variable_structural(vr[i])) {
      fmi_error(c, "%s: %s is a structural parameter, of type UInt64 (fmi3GetUInt64, fmi3SetUInt64)", function,
                model_variable(vr[i])->name);
      return 1;
    }
  return 0;
}

/* Float64 values: the scalars', `time` from the instance, each array's elements in turn. The
 * value references are expanded to one per value (an array's to its elements', model.h), which
 * the shared layer reads as scalars. */
fmi3Status fmi3GetFloat64(fmi3Instance component, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (nValueReferences == 0) return fmi3OK;
  if (!valueReferences || !values) return (fmi3Status)fmi_error(c, "%s: vr[] and value[] must not be NULL", __func__);
  size_t total = 0;
  for (size_t i = 0; i < nValueReferences; i++) {
    const int a = array_of(valueReferences[i]);
    total += a < 0 ? 1 : model_array_length(c->model, (unsigned)a);
  }
  if (total != nValues)
    return (fmi3Status)fmi_error(c,
                                 "%s: nValues = %zu for %zu value references, whose values number %zu (an array "
                                 "counts its elements at the current structural parameters)",
                                 __func__, nValues, nValueReferences, total);
  unsigned* vr = malloc((total ? total : 1) * sizeof *vr);
  if (!vr) return (fmi3Status)fmi_error(c, "%s: out of memory", __func__);
  size_t k = 0;
  for (size_t i = 0; i < nValueReferences; i++) {
    const int a = array_of(valueReferences[i]);
    if (a < 0) {
      vr[k++] = valueReferences[i];
      continue;
    }
    const size_t length = model_array_length(c->model, (unsigned)a);
    for (size_t e = 0; e < length; e++) vr[k++] = MODEL_ELEMENT_VR((unsigned)a, e);
  }
  fmi3Status status = fmi3OK;
  const unsigned t = time_vr();
  size_t from = 0; /* runs without `time` in one call (the outputs are evaluated once), time apart */
  for (size_t i = 0; i <= total && status == fmi3OK; i++) {
    if (i < total && vr[i] != t) continue;
    if (i > from) {
      if (not_intermediate(outer, __func__, &vr[from], i - from)) status = fmi3Error;
      else status = (fmi3Status)fmi_get_values(c, __func__, MODEL_Real, &vr[from], i - from, &values[from], 1);
    }
    if (i < total) values[i] = c->time;
    from = i + 1;
  }
  free(vr);
  return status;
}

fmi3Status fmi3GetInt32(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (structural_as_int32(c, __func__, valueReferences, nValueReferences)) return fmi3Error;
  if (not_intermediate(outer, __func__, valueReferences, nValueReferences)) return fmi3Error;
  return (fmi3Status)fmi_get_values(c, __func__, MODEL_Integer, valueReferences, nValueReferences, values, 1);
}

fmi3Status fmi3GetBoolean(fmi3Instance component, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (not_intermediate(outer, __func__, valueReferences, nValueReferences)) return fmi3Error;
  return (fmi3Status)fmi_get_values(c, __func__, MODEL_Boolean, valueReferences, nValueReferences, values,
                                    sizeof(fmi3Boolean));
}

fmi3Status fmi3GetString(fmi3Instance component, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3String values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (not_intermediate(outer, __func__, valueReferences, nValueReferences)) return fmi3Error;
  return (fmi3Status)fmi_get_values(c, __func__, MODEL_String, valueReferences, nValueReferences, (void*)values, 1);
}

fmi3Status fmi3SetFloat64(fmi3Instance component, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  for (size_t i = 0; i < nValueReferences && valueReferences; i++)
    if (valueReferences[i] == time_vr())
      return (fmi3Status)fmi_error(c, "%s: time (value reference %u) is the independent variable and cannot be set",
                                   __func__, time_vr());
  return (fmi3Status)fmi_set_values(c, __func__, MODEL_Real, valueReferences, nValueReferences, values, 1);
}

fmi3Status fmi3SetInt32(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (structural_as_int32(c, __func__, valueReferences, nValueReferences)) return fmi3Error;
  return (fmi3Status)fmi_set_values(c, __func__, MODEL_Integer, valueReferences, nValueReferences, values, 1);
}

fmi3Status fmi3SetBoolean(fmi3Instance component, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  return (fmi3Status)fmi_set_values(c, __func__, MODEL_Boolean, valueReferences, nValueReferences, values,
                                    sizeof(fmi3Boolean));
}

fmi3Status fmi3SetString(fmi3Instance component, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3String values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  return (fmi3Status)fmi_set_values(c, __func__, MODEL_String, valueReferences, nValueReferences, values, 1);
}

/* The types this FMU has no variables of: a value reference of them is an error naming it. */
#define NO_VARIABLES_GET(name, type)                                                                    \
  fmi3Status fmi3Get##name(fmi3Instance component, const fmi3ValueReference valueReferences[],           \
                           size_t nValueReferences, type values[], size_t nValues) {                    \
    (void)values, (void)nValues;                                                                        \
    CHECK_MODE(FMI_MASK_GET_VALUES);                                                                    \
    if (nValueReferences == 0) return fmi3OK;                                                           \
    return (fmi3Status)fmi_error(c, "%s: value reference %u is not a variable of type " #name, __func__, \
                                 valueReferences ? valueReferences[0] : 0u);                           \
  }
#define NO_VARIABLES_SET(name, type)                                                                    \
  fmi3Status fmi3Set##name(fmi3Instance component, const fmi3ValueReference valueReferences[],           \
                           size_t nValueReferences, const type values[], size_t nValues) {              \
    (void)values, (void)nValues;                                                                        \
    CHECK_MODE(FMI_MASK_SET_VALUES);                                                                    \
    if (nValueReferences == 0) return fmi3OK;                                                           \
    return (fmi3Status)fmi_error(c, "%s: value reference %u is not a variable of type " #name, __func__, \
                                 valueReferences ? valueReferences[0] : 0u);                           \
  }
#define NO_VARIABLES(name, type) NO_VARIABLES_GET(name, type) NO_VARIABLES_SET(name, type)
NO_VARIABLES(Float32, fmi3Float32)
NO_VARIABLES(Int8, fmi3Int8)
NO_VARIABLES(UInt8, fmi3UInt8)
NO_VARIABLES(Int16, fmi3Int16)
NO_VARIABLES(UInt16, fmi3UInt16)
NO_VARIABLES(UInt32, fmi3UInt32)
NO_VARIABLES(Int64, fmi3Int64)

/* UInt64: the structural parameters (Integer parameters of the model), read and set as ints. */
static int only_structural(fmi_instance* c, const char* function, const fmi3ValueReference vr[], size_t n) {
  for (size_t i = 0; i < n && vr; i++)
    if (!model_variable_structural(vr[i])) {
      fmi_error(c, "%s: value reference %u is not a variable of type UInt64 (the structural parameters)", function,
                (unsigned)vr[i]);
      return 1;
    }
  return 0;
}

fmi3Status fmi3GetUInt64(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt64 values[], size_t nValues) {
  CHECK_MODE(FMI_MASK_GET_VALUES | FMI_CONFIGURATION | FMI_INSTANTIATED);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (nValueReferences == 0) return fmi3OK;
  if (!valueReferences || !values) return (fmi3Status)fmi_error(c, "%s: vr[] and value[] must not be NULL", __func__);
  if (only_structural(c, __func__, valueReferences, nValueReferences)) return fmi3Error;
  for (size_t i = 0; i < nValueReferences; i++) values[i] = (fmi3UInt64)model_get_int(c->model, valueReferences[i]);
  return fmi3OK;
}

fmi3Status fmi3SetUInt64(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt64 values[], size_t nValues) {
  CHECK_MODE(FMI_INSTANTIATED | FMI_CONFIGURATION);
  if (scalars(c, __func__, nValueReferences, nValues) != fmi3OK) return fmi3Error;
  if (nValueReferences == 0) return fmi3OK;
  if (!valueReferences || !values) return (fmi3Status)fmi_error(c, "%s: vr[] and value[] must not be NULL", __func__);
  if (only_structural(c, __func__, valueReferences, nValueReferences)) return fmi3Error;
  int* ints = malloc(nValueReferences * sizeof *ints);
  if (!ints) return (fmi3Status)fmi_error(c, "%s: out of memory", __func__);
  fmi3Status status = fmi3OK;
  for (size_t i = 0; i < nValueReferences && status == fmi3OK; i++) {
    if (values[i] > (fmi3UInt64)0x7FFFFFFF)
      status = (fmi3Status)fmi_error(c, "%s: %s = %llu is out of range; it keeps %d", __func__,
                                     model_variable(valueReferences[i])->name, (unsigned long long)values[i],
                                     model_get_int(c->model, valueReferences[i]));
    else
      ints[i] = (int)values[i];
  }
  if (status == fmi3OK)
    status = (fmi3Status)fmi_set_values(c, __func__, MODEL_Integer, valueReferences, nValueReferences, ints, 1);
  free(ints);
  return status;
}

fmi3Status fmi3GetBinary(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
  (void)valueSizes, (void)values, (void)nValues;
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (nValueReferences == 0) return fmi3OK;
  return (fmi3Status)fmi_error(c, "%s: value reference %u is not a variable of type Binary", __func__,
                               valueReferences ? valueReferences[0] : 0u);
}

fmi3Status fmi3SetBinary(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
  (void)valueSizes, (void)values, (void)nValues;
  CHECK_MODE(FMI_MASK_SET_VALUES);
  if (nValueReferences == 0) return fmi3OK;
  return (fmi3Status)fmi_error(c, "%s: value reference %u is not a variable of type Binary", __func__,
                               valueReferences ? valueReferences[0] : 0u);
}

fmi3Status fmi3GetClock(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
  (void)valueReferences, (void)nValueReferences, (void)values;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance component, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
  (void)valueReferences, (void)nValueReferences, (void)values;
  UNSUPPORTED("this FMU has no clocks");
}

/* ---- dependencies ----------------------------------------------------------------------- */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance component, fmi3ValueReference valueReference,
                                               size_t* nDependencies) {
  (void)valueReference, (void)nDependencies;
  UNSUPPORTED("the dependencies are those of modelDescription.xml's <ModelStructure>");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance component, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
  (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
  (void)dependencyKinds, (void)nDependencies;
  UNSUPPORTED("the dependencies are those of modelDescription.xml's <ModelStructure>");
}

/* ---- FMU state (the format: fmi_instance.c) --------------------------------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance component, fmi3FMUState* FMUState) {
  CHECK_MODE(FMI_MASK_GET_STATE);
  return (fmi3Status)fmi_get_state(c, __func__, FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance component, fmi3FMUState FMUState) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_set_state(c, __func__, FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance component, fmi3FMUState* FMUState) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_free_state(c, __func__, FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance component, fmi3FMUState FMUState, size_t* size) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_state_size(c, __func__, FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance component, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_serialize_state(c, __func__, FMUState, serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance component, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi3Status)fmi_deserialize_state(c, __func__, serializedState, size, FMUState);
}

/* ---- derivatives ------------------------------------------------------------------------ */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance component, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (nSeed != nKnowns || nSensitivity != nUnknowns)
    return (fmi3Status)fmi_error(c, "%s: nSeed = %zu for %zu knowns, nSensitivity = %zu for %zu unknowns; allowed: "
                                    "equal (no variable is an array)",
                                 __func__, nSeed, nKnowns, nSensitivity, nUnknowns);
  return (fmi3Status)fmi_directional_derivative(c, __func__, unknowns, nUnknowns, knowns, nKnowns, seed, sensitivity);
}

/* The adjoint, seed^T J, from one directional derivative per known: J's columns. */
fmi3Status fmi3GetAdjointDerivative(fmi3Instance component, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (nSeed != nUnknowns || nSensitivity != nKnowns)
    return (fmi3Status)fmi_error(c, "%s: nSeed = %zu for %zu unknowns, nSensitivity = %zu for %zu knowns; allowed: "
                                    "equal (no variable is an array)",
                                 __func__, nSeed, nUnknowns, nSensitivity, nKnowns);
  if (nKnowns == 0) return fmi3OK;
  CHECK_POINTER(knowns);
  CHECK_POINTER(sensitivity);
  if (nUnknowns) CHECK_POINTER(seed);
  double* column = malloc((nUnknowns ? nUnknowns : 1) * sizeof *column);
  if (!column) return (fmi3Status)fmi_error(c, "%s: out of memory", __func__);
  const double one = 1.0;
  for (size_t k = 0; k < nKnowns; k++) {
    fmi_status s = fmi_directional_derivative(c, __func__, unknowns, nUnknowns, &knowns[k], 1, &one, column);
    if (s != FMI_OK) {
      free(column);
      return (fmi3Status)s;
    }
    double sum = 0;
    for (size_t j = 0; j < nUnknowns; j++) sum += seed[j] * column[j];
    sensitivity[k] = sum;
  }
  free(column);
  return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
  (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
  UNSUPPORTED("maxOutputDerivativeOrder=\"0\"");
}

/* ---- the step --------------------------------------------------------------------------- */

fmi3Status fmi3DoStep(fmi3Instance component, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean* eventHandlingNeeded, fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn,
                      fmi3Float64* lastSuccessfulTime) {
  (void)noSetFMUStatePriorToCurrentPoint;
  CHECK_MODE(FMI_STEP);
  CHECK_POINTER(eventHandlingNeeded);
  CHECK_POINTER(terminateSimulation);
  CHECK_POINTER(earlyReturn);
  CHECK_POINTER(lastSuccessfulTime);
  const fmi_status s = fmi_do_step(c, __func__, currentCommunicationPoint, communicationStepSize);
  *eventHandlingNeeded = fmi3False;
  *terminateSimulation = fmi3False;
  *earlyReturn = fmi3False;
  *lastSuccessfulTime = c->time; /* a discarded step changed nothing: its start */
  return (fmi3Status)s;
}

/* ---- what co-simulation without event mode does not have -------------------------------- */

/* Configuration Mode: the structural parameters (model.slices, dynamics.mesh_orders: the arrays' dimensions
 * name) are set there; also before initialization, as every fixed parameter. */
fmi3Status fmi3EnterConfigurationMode(fmi3Instance component) {
  CHECK_MODE(FMI_INSTANTIATED);
  c->mode = FMI_CONFIGURATION;
  return fmi3OK;
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance component) {
  CHECK_MODE(FMI_CONFIGURATION);
  c->mode = FMI_INSTANTIATED;
  return fmi3OK;
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
  (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
  (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance component, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
  (void)valueReferences, (void)nValueReferences, (void)shifts;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
  (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
  (void)valueReferences, (void)nValueReferences, (void)intervals;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
  (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance component, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
  (void)valueReferences, (void)nValueReferences, (void)shifts;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance component, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
  (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
  UNSUPPORTED("this FMU has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance component) {
  UNSUPPORTED("this FMU has no event mode");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance component, fmi3Boolean* discreteStatesNeedUpdate,
                                    fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged,
                                    fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,
                                    fmi3Float64* nextEventTime) {
  (void)discreteStatesNeedUpdate, (void)terminateSimulation, (void)nominalsOfContinuousStatesChanged;
  (void)valuesOfContinuousStatesChanged, (void)nextEventTimeDefined, (void)nextEventTime;
  UNSUPPORTED("this FMU has no event mode");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance component) {
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance component, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation) {
  (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3SetTime(fmi3Instance component, fmi3Float64 time) {
  (void)time;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance component, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
  (void)continuousStates, (void)nContinuousStates;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance component, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
  (void)derivatives, (void)nContinuousStates;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance component, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
  (void)eventIndicators, (void)nEventIndicators;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance component, fmi3Float64 continuousStates[], size_t nContinuousStates) {
  (void)continuousStates, (void)nContinuousStates;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance component, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
  (void)nominals, (void)nContinuousStates;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance component, size_t* nEventIndicators) {
  (void)nEventIndicators;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance component, size_t* nContinuousStates) {
  (void)nContinuousStates;
  UNSUPPORTED("model exchange");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance component, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
  (void)clockReference, (void)activationTime;
  UNSUPPORTED("scheduled execution");
}
