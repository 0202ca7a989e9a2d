/* Generic FMI 2.0 co-simulation layer: every fmi2* function of the CS API, mapped onto the
 * shared instance (fmi_instance.h) and model.h and nothing else of the model (its identifier,
 * GUID, variables and log categories come through model.h), so it serves another model unchanged.
 *
 * Each function first checks the instance's mode against its mask of allowed modes (an illegal
 * call logs "Illegal call sequence" and returns fmi2Error without changing anything). Errors are
 * logged and returned; only a failed evaluation in fmi2DoStep puts the instance into the Error
 * mode, from which fmi2SetFMUstate or fmi2Reset recover. Memory comes from malloc
 * (canNotUseMemoryManagementFunctions="true").
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmi_instance.h"
#include "model.h"
#include "uri.h"

_Static_assert((int)fmi2OK == FMI_OK && (int)fmi2Warning == FMI_WARNING && (int)fmi2Discard == FMI_DISCARD &&
                   (int)fmi2Error == FMI_ERROR && (int)fmi2Fatal == FMI_FATAL,
               "fmi2Status numbers the statuses as fmi_status does");
_Static_assert(sizeof(fmi2ValueReference) == sizeof(unsigned) && sizeof(fmi2Integer) == sizeof(int) &&
                   sizeof(fmi2Boolean) == sizeof(int) && sizeof(fmi2Real) == sizeof(double),
               "the fmi2 value types are the C types of model.h");

static const fmi_api api = {"fmi2", "FMI 2.0", "FMUstate", "stepComplete", "fmi2LastSuccessfulTime"};

/* The importer's logger behind the shared instance's: the message through "%s", so that a '%' in
 * it or in the instance name is never read as a conversion. */
typedef struct logger_box {
  fmi2CallbackLogger logger;
  fmi2ComponentEnvironment environment;
} logger_box;

static void fmi2_log(void* environment, const char* name, fmi_status status, const char* category,
                     const char* message) {
  const logger_box* box = environment;
  box->logger(box->environment, name, (fmi2Status)status, category, "%s", message);
}

/* The instance: the shared one and the importer's logger it logs through. */
typedef struct instance {
  fmi_instance* shared;
  logger_box box;
} instance;

#define CHECK_MODE(allowed)                                                   \
  instance* outer = (instance*)component;                                    \
  fmi_instance* c = outer ? outer->shared : NULL;                           \
  if (fmi_illegal(c, __func__, (allowed))) return fmi2Error

#define CHECK_POINTER(p)                                                      \
  if (!(p)) return (fmi2Status)fmi_error(c, "%s: argument %s must not be NULL", __func__, #p)

/* ---- common functions ------------------------------------------------------------------- */

const char* fmi2GetTypesPlatform(void) {
  return fmi2TypesPlatform;
}

const char* fmi2GetVersion(void) {
  return fmi2Version;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)visible;
  if (!functions) return NULL;
  instance* outer = calloc(1, sizeof *outer);
  logger_box box = {functions->logger, functions->componentEnvironment};
  /* stands in for the instance while refusing, so that the refusal is logged */
  fmi_instance probe = {.api = &api,
                        .logger = functions->logger ? fmi2_log : NULL,
                        .environment = outer ? (void*)&outer->box : (void*)&box,
                        .name = (char*)(instanceName && instanceName[0] ? instanceName : model_identifier)};
  if (outer) outer->box = box;
  if (!outer) {
    fmi_error(&probe, "fmi2Instantiate: out of memory");
    return NULL;
  }
  if (!instanceName || !instanceName[0]) {
    fmi_error(&probe, "fmi2Instantiate: instanceName must be a non-empty string");
    free(outer);
    return NULL;
  }
  if (fmuType != fmi2CoSimulation) {
    fmi_error(&probe, "fmi2Instantiate: %s is a co-simulation FMU (fmuType = %d)", model_identifier, (int)fmuType);
    free(outer);
    return NULL;
  }
  if (!fmuGUID || strcmp(fmuGUID, model_guid) != 0) {
    fmi_error(&probe,
              "fmi2Instantiate: GUID %s does not match this binary's %s (modelDescription.xml is from another build)",
              fmuGUID ? fmuGUID : "(NULL)", model_guid);
    free(outer);
    return NULL;
  }
  char* resources = fmu_uri_to_path(fmuResourceLocation);
  char note[1200];
  snprintf(note, sizeof note, "resource location is not a local file URI: %s",
           fmuResourceLocation ? fmuResourceLocation : "");
  outer->shared = fmi_instantiate("fmi2Instantiate", &probe, instanceName, loggingOn != fmi2False, resources,
                                  fmuResourceLocation && !resources ? note : NULL);
  if (!outer->shared) {
    free(outer);
    return NULL;
  }
  return outer;
}

void fmi2FreeInstance(fmi2Component component) {
  instance* outer = (instance*)component;
  if (!outer) return;
  fmi_free(outer->shared);
  free(outer);
}

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_set_debug_logging(c, __func__, loggingOn != fmi2False, nCategories, categories);
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  (void)toleranceDefined; /* a model's solvers have their own tolerance parameters */
  (void)tolerance;
  CHECK_MODE(FMI_INSTANTIATED);
  return (fmi2Status)fmi_setup(c, __func__, startTime, stopTimeDefined != fmi2False, stopTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
  CHECK_MODE(FMI_INSTANTIATED);
  return (fmi2Status)fmi_enter_initialization(c, __func__);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
  CHECK_MODE(FMI_INITIALIZATION);
  return (fmi2Status)fmi_exit_initialization(c, __func__);
}

/* Not FMI: whether the instance's parameters and inputs would pass fmi2ExitInitializationMode as far
 * as that is known without reading a file or building the model (model_check; GearMesh's core:
 * gm_model_check). fmi2OK and msg "", or fmi2Error and msg the message initialization would log
 * after the function's name. Logs nothing and changes nothing. Before fmi2ExitInitializationMode
 * and after, until the instance is terminated. */
FMI2_Export fmi2Status gearmesh_check(fmi2Component component, char* msg, size_t msg_size) {
  CHECK_MODE(FMI_INSTANTIATED | FMI_INITIALIZATION | FMI_STEP);
  CHECK_POINTER(msg);
  char text[sizeof c->msg];
  const int failed = model_check(c->model, text, sizeof text);
  if (msg_size) snprintf(msg, msg_size, "%s", failed ? text : "");
  return failed ? fmi2Error : fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
  CHECK_MODE(FMI_STEP);
  return (fmi2Status)fmi_terminate(c, __func__);
}

fmi2Status fmi2Reset(fmi2Component component) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_reset(c, __func__);
}

/* ---- values ----------------------------------------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  return (fmi2Status)fmi_get_values(c, __func__, MODEL_Real, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  return (fmi2Status)fmi_get_values(c, __func__, MODEL_Integer, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  return (fmi2Status)fmi_get_values(c, __func__, MODEL_Boolean, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  return (fmi2Status)fmi_get_values(c, __func__, MODEL_String, vr, nvr, (void*)value, sizeof(fmi2Boolean));
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  return (fmi2Status)fmi_set_values(c, __func__, MODEL_Real, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  return (fmi2Status)fmi_set_values(c, __func__, MODEL_Integer, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  return (fmi2Status)fmi_set_values(c, __func__, MODEL_Boolean, vr, nvr, value, sizeof(fmi2Boolean));
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
  CHECK_MODE(FMI_MASK_SET_VALUES);
  return (fmi2Status)fmi_set_values(c, __func__, MODEL_String, vr, nvr, value, sizeof(fmi2Boolean));
}

/* ---- FMU state (the format: fmi_instance.c) --------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate* FMUstate) {
  CHECK_MODE(FMI_MASK_GET_STATE);
  return (fmi2Status)fmi_get_state(c, __func__, FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate FMUstate) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_set_state(c, __func__, FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate* FMUstate) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_free_state(c, __func__, FMUstate);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate FMUstate, size_t* size) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_state_size(c, __func__, FMUstate, size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_serialize_state(c, __func__, FMUstate, (unsigned char*)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate* FMUstate) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_deserialize_state(c, __func__, (const unsigned char*)serializedState, size, FMUstate);
}

/* ---- directional derivatives ------------------------------------------------------------ */

/* d(outputs)/d(inputs) . dvKnown (fmi_directional_derivative), at the current inputs, to which
 * the outputs read belong (docs/fmi.md, "Feedthrough"). Knowns: Real inputs only (FMI 2.0 also
 * allows parameters as knowns for initial unknowns in Initialization Mode; this layer does not: a
 * parameter known is an error naming it), each with a finite dvKnown. Unknowns: Real outputs.
 * The FMU's state is not changed. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  CHECK_MODE(FMI_MASK_GET_VALUES);
  if (nUnknown == 0) return fmi2OK;
  CHECK_POINTER(vUnknown_ref);
  CHECK_POINTER(dvUnknown);
  if (nKnown) {
    CHECK_POINTER(vKnown_ref);
    CHECK_POINTER(dvKnown);
  }
  return (fmi2Status)fmi_directional_derivative(c, __func__, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                                                dvUnknown);
}

/* ---- capabilities this FMU does not provide --------------------------------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  CHECK_MODE(FMI_MASK_SET_VALUES);
  return (fmi2Status)fmi_error(c, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs=\"false\")");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  CHECK_MODE(FMI_MASK_GET_VALUES);
  return (fmi2Status)fmi_error(c, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder=\"0\")");
}

fmi2Status fmi2CancelStep(fmi2Component component) {
  CHECK_MODE(FMI_ANY_MODE);
  return (fmi2Status)fmi_error(c, "fmi2CancelStep: not supported: fmi2DoStep is synchronous and never pending");
}

/* ---- co-simulation ---------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  CHECK_MODE(FMI_STEP);
  return (fmi2Status)fmi_do_step(c, __func__, currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status* value) {
  CHECK_MODE(FMI_MASK_STATUS);
  CHECK_POINTER(value);
  return (fmi2Status)fmi_discard(c, "fmi2GetStatus(%d): not available: fmi2DoStep never returns fmi2Pending", (int)s);
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real* value) {
  CHECK_MODE(FMI_MASK_STATUS);
  CHECK_POINTER(value);
  if (s != fmi2LastSuccessfulTime) return (fmi2Status)fmi_discard(c, "fmi2GetRealStatus(%d): not available", (int)s);
  *value = c->time;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer* value) {
  CHECK_MODE(FMI_MASK_STATUS);
  CHECK_POINTER(value);
  return (fmi2Status)fmi_discard(c, "fmi2GetIntegerStatus(%d): not available", (int)s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean* value) {
  CHECK_MODE(FMI_MASK_STATUS);
  CHECK_POINTER(value);
  if (s != fmi2Terminated) return (fmi2Status)fmi_discard(c, "fmi2GetBooleanStatus(%d): not available", (int)s);
  *value = fmi2False; /* the FMU never asks to end the simulation */
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String* value) {
  CHECK_MODE(FMI_MASK_STATUS);
  CHECK_POINTER(value);
  return (fmi2Status)fmi_discard(c, "fmi2GetStringStatus(%d): not available: fmi2DoStep never returns fmi2Pending",
                                 (int)s);
}
