/* Ramps: the smallest FMI 2.0 co-simulation FMU the master tests need as a second model: four
 * outputs y<i> = a<i> + b<i> t, with the parameters a<i> (value at t = 0) and b<i> (slope per
 * second). Wired to GearMesh it is a motor held at a speed (an angle ramp and its constant
 * speed) and a constant brake or load torque (tests/python/test_masters.py). Value references:
 * a1..a4 = 0..3, b1..b4 = 4..7, y1..y4 = 8..11 (modelDescription.xml beside this file). */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define N 4

typedef struct {
  double a[N], b[N], time;
  fmi2CallbackLogger logger;
  fmi2ComponentEnvironment env;
  char name[64];
} ramps;

static fmi2Status fail(ramps* r, const char* message) {
  if (r && r->logger) r->logger(r->env, r->name, fmi2Error, "logStatusError", "%s", message);
  return fmi2Error;
}

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions* functions, fmi2Boolean visible, fmi2Boolean logging) {
  (void)guid, (void)resources, (void)visible, (void)logging;
  if (type != fmi2CoSimulation) return NULL;
  ramps* r = calloc(1, sizeof *r);
  if (!r) return NULL;
  if (functions) r->logger = functions->logger, r->env = functions->componentEnvironment;
  strncpy(r->name, name ? name : "ramps", sizeof r->name - 1);
  return r;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
  (void)c, (void)on, (void)n, (void)categories;
  return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolerance_defined, fmi2Real tolerance,
                               fmi2Real start, fmi2Boolean stop_defined, fmi2Real stop) {
  (void)tolerance_defined, (void)tolerance, (void)stop_defined, (void)stop;
  ((ramps*)c)->time = start;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
  ramps* r = c;
  memset(r->a, 0, sizeof r->a), memset(r->b, 0, sizeof r->b), r->time = 0.0;
  return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
  ramps* r = c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] < N) value[i] = r->a[vr[i]];
    else if (vr[i] < 2 * N) value[i] = r->b[vr[i] - N];
    else if (vr[i] < 3 * N) value[i] = r->a[vr[i] - 2 * N] + r->b[vr[i] - 2 * N] * r->time;
    else return fail(r, "fmi2GetReal: unknown value reference");
  }
  return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
  ramps* r = c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] < N) r->a[vr[i]] = value[i];
    else if (vr[i] < 2 * N) r->b[vr[i] - N] = value[i];
    else return fail(r, "fmi2SetReal: only the parameters a<i>, b<i> can be set");
  }
  return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_state) {
  (void)no_set_state;
  ramps* r = c;
  if (!(h >= 0.0)) return fail(r, "fmi2DoStep: negative step");
  r->time = t + h;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
  if (s != fmi2LastSuccessfulTime) return fail(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime");
  *value = ((ramps*)c)->time;
  return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
  if (s != fmi2Terminated) return fail(c, "fmi2GetBooleanStatus: only fmi2Terminated");
  *value = fmi2False;
  return fmi2OK;
}

/* The state is a copy of the instance (masters that roll back ask every FMU for it). */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) {
  if (!*s && !(*s = malloc(sizeof(ramps)))) return fail(c, "fmi2GetFMUstate: out of memory");
  memcpy(*s, c, sizeof(ramps));
  return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
  if (!s) return fail(c, "fmi2SetFMUstate: NULL state");
  memcpy(c, s, sizeof(ramps));
  return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) {
  (void)c;
  free(*s);
  *s = NULL;
  return fmi2OK;
}

/* Not supported (the modelDescription says so): an error if called. */
#define UNSUPPORTED(signature, name) \
  fmi2Status signature { return fail(c, name ": not supported"); }
UNSUPPORTED(fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]), "fmi2GetInteger")
UNSUPPORTED(fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]), "fmi2GetBoolean")
UNSUPPORTED(fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]), "fmi2GetString")
UNSUPPORTED(fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]), "fmi2SetInteger")
UNSUPPORTED(fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]), "fmi2SetBoolean")
UNSUPPORTED(fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]), "fmi2SetString")
UNSUPPORTED(fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t* n), "fmi2SerializedFMUstateSize")
UNSUPPORTED(fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n), "fmi2SerializeFMUstate")
UNSUPPORTED(fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate* s), "fmi2DeSerializeFMUstate")
UNSUPPORTED(fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[],
                                         size_t nz, const fmi2Real du[], fmi2Real dz[]), "fmi2GetDirectionalDerivative")
UNSUPPORTED(fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                        const fmi2Real v[]), "fmi2SetRealInputDerivatives")
UNSUPPORTED(fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                         fmi2Real v[]), "fmi2GetRealOutputDerivatives")
UNSUPPORTED(fmi2CancelStep(fmi2Component c), "fmi2CancelStep")
UNSUPPORTED(fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* v), "fmi2GetStatus")
UNSUPPORTED(fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* v), "fmi2GetIntegerStatus")
UNSUPPORTED(fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* v), "fmi2GetStringStatus")
