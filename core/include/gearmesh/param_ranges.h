/* Static ranges of the FMU's parameters: the one table (core/src/param_ranges.cpp) that the
 * core's validation, the FMU binary and modelDescription.xml's min/max
 * (modelDescription/generate_model_description.c) all read; the Python scene checks read them
 * back from modelDescription.xml (python/gearmesh/param_ranges.py).
 *
 * A range is static: its bounds are constants. Bounds that depend on other parameters (e.g.
 * pair.rack_dedendum > pair.rack_addendum) are further checks after the static one
 * (core/src/params.cpp); the static range is then the envelope of every admissible case.
 * FMI 2.0 has no open bounds: for a bound marked open, min/max state its value and the
 * variable's description says "exclusive" (modelDescription.xml also carries the flag in the
 * variable's Annotations, for tools).
 */
#ifndef GEARMESH_PARAM_RANGES_H
#define GEARMESH_PARAM_RANGES_H

#include <stddef.h>

#include "gearmesh/gearmesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct gm_param_range {
  const char* name; /* FMU variable name, e.g. "gear1.teeth" */
  double lo, hi;    /* bounds in SI; -HUGE_VAL / HUGE_VAL: none */
  int lo_open;      /* 1: value > lo, 0: value >= lo */
  int hi_open;      /* 1: value < hi, 0: value <= hi */
  const char* unit; /* the FMU variable's unit, "" for none */
} gm_param_range;

/* The whole table; *count rows. */
const gm_param_range* gm_param_ranges(size_t* count);

/* The row of FMU variable `name`, or NULL when it has no static range. */
const gm_param_range* gm_param_range_find(const char* name);

/* GM_OK when value is finite and inside r; else GM_ERR_PARAMETER with
 * msg = "<name> = <value> <unit>: allowed range [lo, hi] <unit>" (round brackets at open or
 * missing bounds). */
gm_status gm_param_range_check(const gm_param_range* r, double value, char* msg, size_t msg_size);

#ifdef __cplusplus
}
#endif

#endif /* GEARMESH_PARAM_RANGES_H */
