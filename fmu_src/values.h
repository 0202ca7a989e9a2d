/* Operations on gm_fmu_values that follow the variable table only (no physics): ownership of
 * String values, the start values of a scene FMU and the values part of the FMU state.
 *
 * Ownership: a String field of a gm_fmu_values is NULL (read as "") or a malloc'd string that
 * this gm_fmu_values owns; the functions below keep it so. */
#ifndef GEARMESH_FMU_VALUES_H
#define GEARMESH_FMU_VALUES_H

#include <stddef.h>

#include "variables.h"

/* Start values of a scene FMU, written by python/gearmesh/scene_fmu.py beside the same start
 * attributes in modelDescription.xml. Format (UTF-8, one value per line, '#' comment lines):
 *   gearmesh-start-values 1
 *   <name> <value>      Real: C-locale decimal; Integer: decimal; Boolean: true | false;
 *                       String: "..." with \" and \\ as the only escapes
 * Only parameters and inputs have start values; each name at most once. */
#define FMU_START_VALUES_FILE "gearmesh-start-values.txt"

/* The String value of var in v, never NULL. */
const char* values_get_string(const gm_fmu_values* v, const gm_fmu_variable* var);
/* Store a malloc'd string (v takes it over) as the value of var; the old one is freed. */
void values_set_string(gm_fmu_values* v, const gm_fmu_variable* var, char* owned);
void values_free_strings(gm_fmu_values* v);
/* *dst = *src with copies of src's strings (dst's previous contents are not looked at). Returns
 * nonzero if out of memory; dst then owns what was copied and is safe to free. */
int values_copy(gm_fmu_values* dst, const gm_fmu_values* src);
/* 1 if a and b agree on every variable of the given causality (Strings by content). */
int values_equal(const gm_fmu_values* a, const gm_fmu_values* b, gm_fmu_causality causality);

/* Apply resources/FMU_START_VALUES_FILE, if the directory has one, to start (all or nothing).
 * resources ends in '/' or is NULL (no file then). *count = values read. Nonzero on error, with
 * msg naming the file, the line and what is allowed. */
int values_read_start_file(gm_fmu_values* start, const char* resources, int* count, char* msg, size_t msg_size);

/* FMU state part, native byte order: u32 variable count | every parameter, input and output in
 * table order: f64 (Real), i32 (Integer, Boolean), u32 length + bytes (String, no NUL).
 * Calculated parameters are not stored: they follow from the parameters. */
size_t values_state_size(const gm_fmu_values* v);
/* Writes values_state_size(v) bytes; returns the end. */
unsigned char* values_state_save(const gm_fmu_values* v, unsigned char* buf);
/* Read the part at *buf (not beyond end) into v, an owning copy, and advance *buf. On error v
 * may be partly overwritten (it stays safe to free) and msg says why. */
int values_state_load(gm_fmu_values* v, const unsigned char** buf, const unsigned char* end, char* msg,
                      size_t msg_size);

#endif /* GEARMESH_FMU_VALUES_H */
