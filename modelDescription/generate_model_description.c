/* Writes modelDescription.xml from the variable table (variables.h). Built and run by CMake.
 *
 * Start values of parameters come from gm_default_params() and min/max from the core's parameter
 * table (gearmesh/parameters.h), so the defaults and the ranges live in the core only. The table
 * is checked here (unique names, legal causality/variability/initial, units defined) so that a
 * bad row fails the build instead of producing an FMU that importers reject.
 *
 * Usage: generate_model_description <output.xml> [<source file>...]
 *        generate_model_description --fmi3 <output.xml>
 * The source files (names inside the FMU's sources/, fmu_src/CMakeLists.txt) are listed in the
 * CoSimulation element's <SourceFiles>. With --fmi3 the same variables as FMI 3.0 (the FMI 3.0
 * layer, fmu_src/fmi3_functions.c): the same value references, plus the independent variable
 * `time` after them (value reference: the number of variables). GM_FMU_GUID and GM_FMU_VERSION
 * come from the header that modelDescription/CMakeLists.txt generates (variables.h includes it).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"
#include "variables.h"

#define N_VARIABLES GM_FMU_VARIABLE_COUNT

static const char* const units[] = {
#define U(name, kg, m, s, rad) name,
    GM_FMU_UNITS(U)
#undef U
};

static const int exponents[][4] = {
#define U(name, kg, m, s, rad) {kg, m, s, rad},
    GM_FMU_UNITS(U)
#undef U
};

static int failures = 0;

static void fail(const char* what, const char* name) {
  fprintf(stderr, "generate_model_description: %s: %s\n", name, what);
  failures++;
}

static int unit_defined(const char* unit) {
  for (size_t i = 0; i < sizeof units / sizeof units[0]; i++)
    if (strcmp(units[i], unit) == 0) return 1;
  return 0;
}

static int display_unit_defined(const char* unit, const char* display) {
#define D(u, name, factor) \
  if (strcmp(u, unit) == 0 && strcmp(name, display) == 0) return 1;
  GM_FMU_DISPLAY_UNITS(D)
#undef D
  return 0;
}

/* The combinations this FMU uses, all legal in FMI 2.0 (spec table of causality/variability/initial). */
static void check_row(const gm_fmu_variable* v, size_t index) {
  static const char* const legal[][3] = {{"parameter", "fixed", "exact"},
                                         {"calculatedParameter", "fixed", "calculated"},
                                         {"input", "continuous", "exact"},
                                         {"input", "discrete", "exact"},
                                         {"output", "continuous", "calculated"},
                                         {"output", "discrete", "calculated"}};
  int ok = 0;
  for (size_t i = 0; i < sizeof legal / sizeof legal[0]; i++)
    ok |= strcmp(legal[i][0], v->causality_name) == 0 && strcmp(legal[i][1], v->variability) == 0 &&
          strcmp(legal[i][2], v->initial) == 0;
  if (!ok) fail("illegal causality/variability/initial combination", v->name);
  if (v->type != GM_FMU_Real && strcmp(v->variability, "continuous") == 0)
    fail("only Real variables can be continuous", v->name);
  if (v->type != GM_FMU_Real && (v->unit[0] || v->display_unit[0])) fail("only Real variables carry units", v->name);
  if (v->unit[0] && !unit_defined(v->unit)) fail("unit not in GM_FMU_UNITS", v->name);
  if (v->display_unit[0] && !display_unit_defined(v->unit, v->display_unit))
    fail("display unit not in GM_FMU_DISPLAY_UNITS for its unit", v->name);
  for (size_t j = 0; j < index; j++)
    if (strcmp(gm_fmu_variables[j].name, v->name) == 0) fail("duplicate name", v->name);
  const gm_param_range* r = gm_param_range_find(v->name);
  if (!r) return;
  if (v->type != GM_FMU_Real && v->type != GM_FMU_Integer) fail("only Real and Integer variables have a range", v->name);
  if (strcmp(r->unit, v->unit) != 0) fail("unit differs from its range's", v->name);
  if (v->type == GM_FMU_Integer && (r->lo != floor(r->lo) || r->hi != floor(r->hi)))
    fail("an Integer's range has whole-number bounds", v->name);
}

/* Every row of the range table names a variable, once, with lo < hi. */
static void check_ranges(void) {
  size_t count;
  const gm_param_range* ranges = gm_param_ranges(&count);
  for (size_t i = 0; i < count; i++) {
    int found = 0;
    for (size_t j = 0; j < N_VARIABLES; j++) found |= strcmp(gm_fmu_variables[j].name, ranges[i].name) == 0;
    if (!found) fail("a static range (gearmesh/parameters.h) names no variable", ranges[i].name);
    for (size_t j = 0; j < i; j++)
      if (strcmp(ranges[j].name, ranges[i].name) == 0)
        fail("two static ranges (gearmesh/parameters.h)", ranges[i].name);
    if (!(ranges[i].lo < ranges[i].hi)) fail("range with lo >= hi (gearmesh/parameters.h)", ranges[i].name);
  }
}

static void put_escaped(FILE* f, const char* s) {
  for (; *s; s++) {
    switch (*s) {
      case '&': fputs("&amp;", f); break;
      case '<': fputs("&lt;", f); break;
      case '>': fputs("&gt;", f); break;
      case '"': fputs("&quot;", f); break;
      default: fputc(*s, f);
    }
  }
}

/* Shortest of %.15g/%.16g/%.17g that reads back to the same double (C locale: no setlocale). */
static void put_real(FILE* f, double x) {
  char buf[32];
  for (int digits = 15; digits <= 17; digits++) {
    snprintf(buf, sizeof buf, "%.*g", digits, x);
    if (strtod(buf, NULL) == x) break;
  }
  fputs(buf, f);
}

/* min or max of a range (none when infinite); Integer bounds as whole numbers. */
static void put_bound(FILE* f, const char* attribute, double x, gm_fmu_type type) {
  if (isinf(x)) return;
  fprintf(f, " %s=\"", attribute);
  if (type == GM_FMU_Integer) fprintf(f, "%.0f", x);
  else put_real(f, x);
  fputc('"', f);
}

/* FMI 2.0 has closed bounds only: an open one is said in the description and, for tools, in the
 * model's <VendorAnnotations><Tool name="GearMesh"><Ranges><Range variable="NAME" minExclusive/
 * maxExclusive="true"/>: at model level, where every importer reads or skips them (fmi-sim 0.7
 * refuses a ScalarVariable's own <Annotations>). */
static const char* open_note(const gm_param_range* r) {
  if (!r || !(r->lo_open || r->hi_open)) return "";
  return r->lo_open && r->hi_open ? " (min and max exclusive)" : r->lo_open ? " (min exclusive)" : " (max exclusive)";
}

static int depends(const gm_fmu_variable* u, const gm_fmu_variable* k, int initialization);
static void put_units(FILE* f, const gm_fmu_variable* v);

/* The value references of the knowns an unknown of dependency classes deps depends on. */
static void put_dependency_refs(FILE* f, unsigned deps, int initialization) {
  gm_fmu_variable unknown = {0};
  unknown.deps = deps;
  size_t k = 0;
  for (size_t j = 0; j < N_VARIABLES; j++)
    if (depends(&unknown, &gm_fmu_variables[j], initialization)) fprintf(f, "%s%zu", k++ ? " " : "", j);
}

/* The value reference of the structural parameter an array's dimension names (GM_FMU_DIM_*). */
static size_t dim_vr(int dim) {
  for (size_t i = 0; i < N_VARIABLES; i++)
    if (gm_fmu_variables[i].offset == gm_fmu_dim_field(dim) && gm_fmu_structural(gm_fmu_variables[i].name)) return i;
  fail("no structural parameter bound to the field an array's dimension names", "GM_FMU_DIM_*");
  return 0;
}

/* FMI 2.0 has no arrays: the arrays (GM_FMU_ARRAYS) are described in <Tool name="GearMesh
 * arrays">, from which a scene FMU lists the elements it needs as Real ScalarVariables (value
 * references model.h's MODEL_ELEMENT_VR: elementBase + flat index; dimensions, a length or the
 * structural parameter's name; the knowns' value references at a communication point and at
 * initialization). */
static void put_array_annotations(FILE* f) {
  fputs("    <Tool name=\"GearMesh arrays\">\n      <Arrays>\n", f);
  for (size_t a = 0; a < GM_FMU_ARRAY_COUNT; a++) {
    const gm_fmu_array* v = &gm_fmu_arrays[a];
    fputs("        <Array name=\"", f);
    put_escaped(f, v->name);
    fprintf(f, "\" elementBase=\"%u\" causality=\"%s\" variability=\"%s\" initial=\"%s\"",
            MODEL_ELEMENT_VR(a, 0), v->causality_name, v->variability, v->initial);
    const gm_fmu_variable units = {.unit = v->unit, .display_unit = v->display_unit};
    put_units(f, &units);
    fputs(" dimensions=\"", f);
    for (int d = 0; d < 2 && v->dims[d]; d++) {
      if (d) fputc(' ', f);
      if (gm_fmu_dim_field(v->dims[d]) != (size_t)-1) put_escaped(f, gm_fmu_variables[dim_vr(v->dims[d])].name);
      else fprintf(f, "%d", v->dims[d]);
    }
    fputs("\"\n          dependencies=\"", f);
    put_dependency_refs(f, v->deps & D_KNOWN_CLASSES, 0);
    fputs("\" initialDependencies=\"", f);
    put_dependency_refs(f, v->deps, 1);
    fputs("\" description=\"", f);
    put_escaped(f, v->description);
    fputs("\"/>\n", f);
  }
  fputs("      </Arrays>\n    </Tool>\n", f);
}

static void put_open_annotations(FILE* f) {
  /* the schema allows one element in a Tool: the Range elements go into one Ranges */
  fputs("  <VendorAnnotations>\n    <Tool name=\"GearMesh\">\n      <Ranges>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_param_range* r = gm_param_range_find(gm_fmu_variables[i].name);
    if (!r || !(r->lo_open || r->hi_open)) continue;
    fputs("        <Range variable=\"", f);
    put_escaped(f, gm_fmu_variables[i].name);
    fputc('"', f);
    if (r->lo_open) fputs(" minExclusive=\"true\"", f);
    if (r->hi_open) fputs(" maxExclusive=\"true\"", f);
    fputs("/>\n", f);
  }
  fputs("      </Ranges>\n    </Tool>\n", f);
  put_array_annotations(f);
}

/* What the tooling needs of a parameter beyond FMI (gearmesh/parameters.h): the stiffness levels
 * and the modes that read it, and its flags, in <Tool name="GearMesh.parameters"><Parameters>
 * <Parameter variable="NAME" levels="0 1" modes="large_step" body="true" file="true"/>; an
 * attribute only where the row differs from every level, every mode, no flag. */
static void put_parameter_annotations(FILE* f) {
  static const char* const modes[] = {"prescribed", "quasi_static", "large_step"};
  fputs("    <Tool name=\"GearMesh.parameters\">\n      <Parameters>\n", f);
  size_t count;
  const gm_param_info* rows = gm_parameters(&count);
  for (size_t i = 0; i < count; i++) {
    const gm_param_info* r = &rows[i];
    if (r->levels == GM_ALL_LEVELS && r->modes == GM_ALL_MODES && !(r->flags & (GM_PARAM_BODY | GM_PARAM_FILE)))
      continue;
    fputs("        <Parameter variable=\"", f);
    put_escaped(f, r->name);
    fputc('"', f);
    if (r->levels != GM_ALL_LEVELS) {
      fputs(" levels=\"", f);
      for (int l = 0, first = 1; l < GM_STIFFNESS_LEVELS; l++)
        if (r->levels & GM_LEVEL(l)) fprintf(f, first ? "%d" : " %d", l), first = 0;
      fputc('"', f);
    }
    if (r->modes != GM_ALL_MODES) {
      fputs(" modes=\"", f);
      for (int m = 0, first = 1; m < 3; m++)
        if (r->modes & (1u << m)) fprintf(f, first ? "%s" : " %s", modes[m]), first = 0;
      fputc('"', f);
    }
    if (r->flags & GM_PARAM_BODY) fputs(" body=\"true\"", f);
    if (r->flags & GM_PARAM_FILE) fputs(" file=\"true\"", f);
    fputs("/>\n", f);
  }
  fputs("      </Parameters>\n    </Tool>\n  </VendorAnnotations>\n", f);
}

/* Every row of the parameter table is a variable of the table (variables.h binds them all). */
static void check_parameters(void) {
  size_t count;
  const gm_param_info* rows = gm_parameters(&count);
  for (size_t i = 0; i < count; i++) {
    int found = 0;
    for (size_t j = 0; j < N_VARIABLES; j++) found |= strcmp(gm_fmu_variables[j].name, rows[i].name) == 0;
    if (!found) fail("a row of gearmesh/parameters.h names no variable", rows[i].name);
  }
}

static void put_start(FILE* f, const gm_fmu_variable* v, const gm_fmu_values* start) {
  const char* field = (const char*)start + v->offset;
  fputs(" start=\"", f);
  if (v->type == GM_FMU_String) {
    const char* s;
    memcpy(&s, field, sizeof s);
    put_escaped(f, s ? s : ""); /* NULL = "", as in the binary */
  } else if (v->type == GM_FMU_Real) {
    double x;
    memcpy(&x, field, sizeof x);
    if (!isfinite(x)) fail("start value is not finite", v->name);
    put_real(f, x);
  } else {
    int i;
    memcpy(&i, field, sizeof i);
    if (v->type == GM_FMU_Integer) fprintf(f, "%d", i);
    else fputs(i ? "true" : "false", f);
  }
  fputc('"', f);
}

/* 1 if unknown u depends on known k at a communication point (<Outputs>: the knowns are the
 * inputs) or at initialization (<InitialUnknowns>: inputs and parameters; the unknown's
 * D_AT_INIT classes count too). */
static int depends(const gm_fmu_variable* u, const gm_fmu_variable* k, int initialization) {
  unsigned classes = u->deps & D_KNOWN_CLASSES;
  if (initialization) classes |= u->deps >> D_INIT_SHIFT;
  const int known = k->causality == GM_FMU_input || (initialization && k->causality == GM_FMU_parameter);
  return known && (k->deps & classes) != 0;
}

/* <Unknown> of variable `index` with its knowns; every dependency is of kind "dependent". */
static void put_unknown(FILE* f, size_t index, int initialization) {
  const gm_fmu_variable* u = &gm_fmu_variables[index];
  fprintf(f, "      <Unknown index=\"%zu\" dependencies=\"", index + 1);
  size_t count = 0;
  for (size_t j = 0; j < N_VARIABLES; j++)
    if (depends(u, &gm_fmu_variables[j], initialization)) fprintf(f, "%s%zu", count++ ? " " : "", j + 1);
  fputs("\" dependenciesKind=\"", f);
  for (size_t i = 0; i < count; i++) fputs(i ? " dependent" : "dependent", f);
  fputs("\"/>\n", f);
}

static void put_type_definitions(FILE* f);

/* The units, log categories and default experiment: the same elements in FMI 2.0 and 3.0 (3.0:
 * with the type definitions that carry the variables' units). */
static void put_common(FILE* f, int fmi3) {
  fputs("  <UnitDefinitions>\n", f);
#define D(unit, name, factor)                                                                  \
  if (strcmp(unit, current) == 0) {                                                            \
    fputs("      <DisplayUnit name=\"", f);                                                    \
    put_escaped(f, name);                                                                      \
    fputs("\" factor=\"", f);                                                                  \
    put_real(f, factor);                                                                       \
    fputs("\"/>\n", f);                                                                        \
  }
  for (size_t u = 0; u < sizeof units / sizeof units[0]; u++) {
    const char* current = units[u];
    fputs("    <Unit name=\"", f);
    put_escaped(f, current);
    fputs("\">\n      <BaseUnit", f);
    static const char* const base[] = {"kg", "m", "s", "rad"};
    for (int b = 0; b < 4; b++)
      if (exponents[u][b]) fprintf(f, " %s=\"%d\"", base[b], exponents[u][b]);
    fputs("/>\n", f);
    GM_FMU_DISPLAY_UNITS(D)
    fputs("    </Unit>\n", f);
  }
#undef D
  fputs("  </UnitDefinitions>\n", f);
  if (fmi3) put_type_definitions(f);

  fputs("  <LogCategories>\n", f);
#define L(id, name, description) \
  fputs("    <Category name=\"" name "\" description=\"", f); \
  put_escaped(f, description);                                \
  fputs("\"/>\n", f);
  GM_FMU_LOG_CATEGORIES(L)
#undef L
  fputs("  </LogCategories>\n", f);

  /* 10 mesh periods at about 1000 rpm, 100 steps per mesh period for the default 57 teeth. */
  fputs("  <DefaultExperiment startTime=\"0\" stopTime=\"0.01\" stepSize=\"1e-05\"/>\n", f);
}

/* FMI 3.0: the type's element name. */
static const char* fmi3_type(gm_fmu_type type) {
  switch (type) {
    case GM_FMU_Real: return "Float64";
    case GM_FMU_Integer: return "Int32";
    case GM_FMU_Boolean: return "Boolean";
    default: return "String";
  }
}

/* FMI 3.0 <Output>/<InitialUnknown> of the variable with value reference vr and dependency
 * classes deps, with its knowns (value references). */
static void put_unknown3(FILE* f, const char* element, size_t vr, unsigned deps, int initialization) {
  gm_fmu_variable unknown = {0};
  unknown.deps = deps;
  const gm_fmu_variable* u = &unknown;
  size_t count = 0;
  for (size_t j = 0; j < N_VARIABLES; j++) count += depends(u, &gm_fmu_variables[j], initialization) != 0;
  fprintf(f, "    <%s valueReference=\"%zu\"", element, vr);
  if (count) {
    fputs(" dependencies=\"", f);
    size_t k = 0;
    for (size_t j = 0; j < N_VARIABLES; j++)
      if (depends(u, &gm_fmu_variables[j], initialization)) fprintf(f, "%s%zu", k++ ? " " : "", j);
    fputs("\" dependenciesKind=\"", f);
    for (size_t i = 0; i < count; i++) fputs(i ? " dependent" : "dependent", f);
    fputc('"', f);
  } else {
    fputs(" dependencies=\"\" dependenciesKind=\"\"", f);
  }
  fputs("/>\n", f);
}

/* FMI 3.0: the unit (and display unit) of a Float64 variable through a Float64Type of
 * <TypeDefinitions>, named for them ("m", "m in um"), which the variable names as declaredType:
 * FMI 3.0 allows unit and displayUnit on the variable too, but fmi-sim (fmi-schema 0.8) reads
 * them only there. */
/* The unit and display unit attributes of v (none if it has none). */
static void put_units(FILE* f, const gm_fmu_variable* v) {
  if (v->unit[0]) {
    fputs(" unit=\"", f);
    put_escaped(f, v->unit);
    fputc('"', f);
  }
  if (v->display_unit[0]) {
    fputs(" displayUnit=\"", f);
    put_escaped(f, v->display_unit);
    fputc('"', f);
  }
}

static void put_type_name(FILE* f, const gm_fmu_variable* v) {
  put_escaped(f, v->unit);
  if (v->display_unit[0]) {
    fputs(" in ", f);
    put_escaped(f, v->display_unit);
  }
}

/* The (unit, display unit) of the table's variable i, then of the arrays' (i - N_VARIABLES). */
static gm_fmu_variable typed(size_t i) {
  if (i < N_VARIABLES) return gm_fmu_variables[i];
  const gm_fmu_array* a = &gm_fmu_arrays[i - N_VARIABLES];
  return (gm_fmu_variable){.unit = a->unit, .display_unit = a->display_unit};
}

static void put_type_definitions(FILE* f) {
  fputs("  <TypeDefinitions>\n", f);
  for (size_t i = 0; i < N_VARIABLES + GM_FMU_ARRAY_COUNT; i++) {
    const gm_fmu_variable v = typed(i);
    if (!v.unit[0]) continue;
    int seen = 0; /* once per (unit, display unit) */
    for (size_t j = 0; j < i && !seen; j++) {
      const gm_fmu_variable w = typed(j);
      seen = strcmp(w.unit, v.unit) == 0 && strcmp(w.display_unit, v.display_unit) == 0;
    }
    if (seen) continue;
    fputs("    <Float64Type name=\"", f);
    put_type_name(f, &v);
    fputc('"', f);
    put_units(f, &v);
    fputs("/>\n", f);
  }
  fputs("    <Float64Type name=\"s\" unit=\"s\"/>\n  </TypeDefinitions>\n", f);
}

#define N_ARRAYS GM_FMU_ARRAY_COUNT
#define ARRAY_VR(a) ((size_t)N_VARIABLES + 1 + (a)) /* after `time` (model.h) */

/* FMI 3.0: the arrays (GM_FMU_ARRAYS), Float64 with their <Dimension>s, after `time`. */
static void put_arrays3(FILE* f) {
  for (size_t a = 0; a < N_ARRAYS; a++) {
    const gm_fmu_array* v = &gm_fmu_arrays[a];
    fputs("    <Float64 name=\"", f);
    put_escaped(f, v->name);
    fprintf(f, "\" valueReference=\"%zu\" description=\"", ARRAY_VR(a));
    put_escaped(f, v->description);
    fprintf(f, "\"\n      causality=\"%s\" variability=\"%s\" initial=\"%s\"", v->causality_name, v->variability,
            v->initial);
    if (v->unit[0]) {
      const gm_fmu_variable units = {.unit = v->unit, .display_unit = v->display_unit};
      fputs(" declaredType=\"", f);
      put_type_name(f, &units);
      fputc('"', f);
    }
    if (gm_fmu_array_intermediate(v)) fputs(" intermediateUpdate=\"true\"", f);
    fputs(">\n", f);
    for (int d = 0; d < 2 && v->dims[d]; d++) {
      if (gm_fmu_dim_field(v->dims[d]) != (size_t)-1)
        fprintf(f, "      <Dimension valueReference=\"%zu\"/>\n", dim_vr(v->dims[d]));
      else fprintf(f, "      <Dimension start=\"%d\"/>\n", v->dims[d]);
    }
    fputs("    </Float64>\n", f);
  }
}

/* modelDescription.xml for FMI 3.0 (co-simulation only): the same variables, start values,
 * ranges, units, categories and dependencies as FMI 2.0's. */
static int write_fmi3(const char* path, const gm_fmu_values* start) {
  FILE* f = fopen(path, "w");
  if (!f) {
    perror(path);
    return 1;
  }
  fprintf(f,
          "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
          "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"GearMesh\" instantiationToken=\"%s\" version=\"%s\"\n"
          "  description=\"Gear-mesh contact element: hybrid FE/analytical reduced-order tooth contact\"\n"
          "  generationTool=\"GearMesh generate_model_description\" variableNamingConvention=\"structured\">\n",
          GM_FMU_GUID, GM_FMU_VERSION);
  fputs("  <CoSimulation modelIdentifier=\"GearMesh\" needsExecutionTool=\"false\"\n"
        "    canBeInstantiatedOnlyOncePerProcess=\"false\" canGetAndSetFMUState=\"true\"\n"
        "    canSerializeFMUState=\"true\" providesDirectionalDerivatives=\"true\"\n"
        "    providesAdjointDerivatives=\"true\" canHandleVariableCommunicationStepSize=\"true\"\n"
        "    maxOutputDerivativeOrder=\"0\" providesIntermediateUpdate=\"true\" hasEventMode=\"false\"/>\n",
        f);
  put_common(f, 1);
  fputs("  <ModelVariables>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    const gm_param_range* r = gm_param_range_find(v->name);
    const int structural = gm_fmu_structural(v->name);
    if (structural && v->type != GM_FMU_Integer) fail("a structural parameter must be an Integer", v->name);
    fprintf(f, "    <%s name=\"", structural ? "UInt64" : fmi3_type(v->type));
    put_escaped(f, v->name);
    fprintf(f, "\" valueReference=\"%zu\" description=\"", i);
    put_escaped(f, v->description);
    put_escaped(f, open_note(r));
    fprintf(f, "\"\n      causality=\"%s\" variability=\"%s\"", structural ? "structuralParameter" : v->causality_name,
            v->variability);
    if (v->causality != GM_FMU_input) fprintf(f, " initial=\"%s\"", v->initial);
    if (v->unit[0]) {
      fputs(" declaredType=\"", f);
      put_type_name(f, v);
      fputc('"', f);
    }
    if (r) {
      put_bound(f, "min", r->lo, v->type);
      put_bound(f, "max", r->hi, v->type);
    }
    if (gm_fmu_follows_spins(v)) fputs(" intermediateUpdate=\"true\"", f);
    const int with_start = strcmp(v->initial, "exact") == 0;
    if (v->type == GM_FMU_String) { /* FMI 3.0: a String's start is a <Start> element */
      if (with_start) {
        const char* text;
        memcpy(&text, (const char*)start + v->offset, sizeof text);
        fputs(">\n      <Start value=\"", f);
        put_escaped(f, text ? text : "");
        fputs("\"/>\n    </String>\n", f);
      } else {
        fputs("/>\n", f);
      }
      continue;
    }
    if (with_start) put_start(f, v, start);
    fputs("/>\n", f);
  }
  /* the independent variable FMI 3.0 asks for, after the table (model.h: model_variable_count) */
  fprintf(f, "    <Float64 name=\"time\" valueReference=\"%zu\" causality=\"independent\" variability=\"continuous\"\n"
             "      declaredType=\"s\" description=\"simulation time\"/>\n",
          (size_t)N_VARIABLES);
  put_arrays3(f);
  fputs("  </ModelVariables>\n  <ModelStructure>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++)
    if (gm_fmu_variables[i].causality == GM_FMU_output) put_unknown3(f, "Output", i, gm_fmu_variables[i].deps, 0);
  for (size_t a = 0; a < N_ARRAYS; a++)
    if (gm_fmu_arrays[a].causality == GM_FMU_output) put_unknown3(f, "Output", ARRAY_VR(a), gm_fmu_arrays[a].deps, 0);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (v->causality == GM_FMU_calculatedParameter ||
        (v->causality == GM_FMU_output && strcmp(v->initial, "exact") != 0))
      put_unknown3(f, "InitialUnknown", i, v->deps, 1);
  }
  for (size_t a = 0; a < N_ARRAYS; a++) /* calculated parameters and outputs, none with a start */
    put_unknown3(f, "InitialUnknown", ARRAY_VR(a), gm_fmu_arrays[a].deps, 1);
  fputs("  </ModelStructure>\n", f);
  /* the open range bounds are in the descriptions only ("(min exclusive)"): fmi-sim's reader takes
   * no elements inside an <Annotation>, where FMI 2.0's VendorAnnotations carry them */
  fputs("</fmiModelDescription>\n", f);
  if (ferror(f) | fclose(f) || failures) {
    fprintf(stderr, "generate_model_description: writing %s failed\n", path);
    remove(path);
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  const int fmi3 = argc == 3 && strcmp(argv[1], "--fmi3") == 0;
  if (argc < 2 || (argv[1][0] == '-' && !fmi3)) {
    fprintf(stderr, "usage: %s <modelDescription.xml> [<source file>...]\n       %s --fmi3 <modelDescription.xml>\n",
            argv[0], argv[0]);
    return 2;
  }
  gm_fmu_values start;
  memset(&start, 0, sizeof start); /* inputs start at the nominal pose, at rest */
  gm_default_params(&start.p);
  gm_dynamics_default_params(&start.dp);
  start.mesh_damping_ratio = GM_MESH_DAMPING_RATIO;
  for (size_t i = 0; i < N_VARIABLES; i++) check_row(&gm_fmu_variables[i], i);
  check_ranges();
  check_parameters();
  if (failures) return 1;
  if (fmi3) return write_fmi3(argv[2], &start);

  FILE* f = fopen(argv[1], "w");
  if (!f) {
    perror(argv[1]);
    return 1;
  }
  fprintf(f,
          "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
          "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"GearMesh\" guid=\"%s\" version=\"%s\"\n"
          "  description=\"Gear-mesh contact element: hybrid FE/analytical reduced-order tooth contact\"\n"
          "  generationTool=\"GearMesh generate_model_description\" variableNamingConvention=\"structured\">\n",
          GM_FMU_GUID, GM_FMU_VERSION);
  fputs("  <CoSimulation modelIdentifier=\"GearMesh\" needsExecutionTool=\"false\"\n"
        "    canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\"\n"
        "    maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\"\n"
        "    canBeInstantiatedOnlyOncePerProcess=\"false\" canNotUseMemoryManagementFunctions=\"true\"\n"
        "    canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\" providesDirectionalDerivative=\"true\"",
        f);
  if (argc > 2) {
    fputs(">\n    <SourceFiles>\n", f);
    for (int i = 2; i < argc; i++) {
      fputs("      <File name=\"", f);
      put_escaped(f, argv[i]);
      fputs("\"/>\n", f);
    }
    fputs("    </SourceFiles>\n  </CoSimulation>\n", f);
  } else {
    fputs("/>\n", f);
  }

  put_common(f, 0);

  put_open_annotations(f);
  put_parameter_annotations(f);
  fputs("  <ModelVariables>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    const gm_param_range* r = gm_param_range_find(v->name);
    fprintf(f, "    <!-- index %zu -->\n    <ScalarVariable name=\"", i + 1);
    put_escaped(f, v->name);
    fprintf(f, "\" valueReference=\"%zu\" description=\"", i);
    put_escaped(f, v->description);
    put_escaped(f, open_note(r));
    fprintf(f, "\"\n      causality=\"%s\" variability=\"%s\"", v->causality_name, v->variability);
    if (v->causality != GM_FMU_input) fprintf(f, " initial=\"%s\"", v->initial); /* inputs carry no initial */
    fprintf(f, ">\n      <%s", v->type_name);
    put_units(f, v);
    if (r) {
      put_bound(f, "min", r->lo, v->type);
      put_bound(f, "max", r->hi, v->type);
    }
    if (strcmp(v->initial, "exact") == 0) put_start(f, v, &start);
    fputs("/>\n", f);
    fputs("    </ScalarVariable>\n", f);
  }
  fputs("  </ModelVariables>\n", f);

  fputs("  <ModelStructure>\n    <Outputs>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++)
    if (gm_fmu_variables[i].causality == GM_FMU_output) put_unknown(f, i, 0);
  fputs("    </Outputs>\n    <InitialUnknowns>\n", f);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* v = &gm_fmu_variables[i];
    if (v->causality == GM_FMU_calculatedParameter ||
        (v->causality == GM_FMU_output && strcmp(v->initial, "exact") != 0))
      put_unknown(f, i, 1);
  }
  fputs("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n", f);

  if (ferror(f) | fclose(f) || failures) {
    fprintf(stderr, "generate_model_description: writing %s failed\n", argv[1]);
    remove(argv[1]);
    return 1;
  }
  return 0;
}
