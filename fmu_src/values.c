/* Table-generic operations on gm_fmu_values (values.h). */
#define _GNU_SOURCE /* strtod_l, newlocale: numbers in the C locale without touching the process's */
#include "values.h"

#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* A C locale of its own for numbers, per platform (docs/platforms.md): POSIX newlocale/strtod_l
 * (on macOS declared in xlocale.h), the Windows C runtime's _create_locale/_strtod_l. */
#ifdef _WIN32
typedef _locale_t locale_t;
#define newlocale(mask, name, base) _create_locale(LC_NUMERIC, name)
#define strtod_l _strtod_l
#define freelocale _free_locale
#elif defined(__APPLE__)
#include <xlocale.h>
#endif

#define N_VARIABLES GM_FMU_VARIABLE_COUNT

/* The text of errno value err, thread-safe: glibc's GNU strerror_r returns it; the XSI strerror_r
 * (macOS) and Windows' strerror_s fill buf. */
static const char* error_text(int err, char* buf, size_t size) {
#if defined(_WIN32)
  if (strerror_s(buf, size, err) != 0) snprintf(buf, size, "error %d", err);
  return buf;
#elif defined(__GLIBC__)
  return strerror_r(err, buf, size);
#else
  if (strerror_r(err, buf, size) != 0) snprintf(buf, size, "error %d", err);
  return buf;
#endif
}

static void* field(const gm_fmu_values* v, const gm_fmu_variable* var) {
  return (char*)v + var->offset;
}

static char* string_field(const gm_fmu_values* v, const gm_fmu_variable* var) {
  char* s;
  memcpy(&s, field(v, var), sizeof s);
  return s;
}

const char* values_get_string(const gm_fmu_values* v, const gm_fmu_variable* var) {
  const char* s = string_field(v, var);
  return s ? s : "";
}

void values_set_string(gm_fmu_values* v, const gm_fmu_variable* var, char* owned) {
  free(string_field(v, var));
  memcpy(field(v, var), &owned, sizeof owned);
}

void values_free_strings(gm_fmu_values* v) {
  for (size_t i = 0; i < N_VARIABLES; i++)
    if (gm_fmu_variables[i].type == GM_FMU_String) values_set_string(v, &gm_fmu_variables[i], NULL);
}

static char* copy_bytes(const char* s, size_t n) {
  char* copy = malloc(n + 1);
  if (!copy) return NULL;
  memcpy(copy, s, n);
  copy[n] = '\0';
  return copy;
}

int values_copy(gm_fmu_values* dst, const gm_fmu_values* src) {
  *dst = *src;
  int failed = 0;
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (var->type != GM_FMU_String) continue;
    const char* s = string_field(src, var);
    char* copy = s ? copy_bytes(s, strlen(s)) : NULL;
    failed |= s && !copy;
    memcpy(field(dst, var), &copy, sizeof copy);
  }
  return failed;
}

static size_t value_size(const gm_fmu_variable* var) {
  return var->type == GM_FMU_Real ? sizeof(double) : sizeof(int32_t); /* int is int32_t on FMI platforms */
}

int values_equal(const gm_fmu_values* a, const gm_fmu_values* b, gm_fmu_causality causality) {
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (var->causality != causality) continue;
    if (var->type == GM_FMU_String ? strcmp(values_get_string(a, var), values_get_string(b, var)) != 0
                                   : memcmp(field(a, var), field(b, var), value_size(var)) != 0)
      return 0;
  }
  return 1;
}

/* ---- start values of a scene FMU ---------------------------------------------------------- */

#define START_FILE_LIMIT (1 << 20)

static const gm_fmu_variable* variable_named(const char* name, size_t n) {
  for (size_t i = 0; i < N_VARIABLES; i++)
    if (strlen(gm_fmu_variables[i].name) == n && memcmp(gm_fmu_variables[i].name, name, n) == 0)
      return &gm_fmu_variables[i];
  return NULL;
}

/* Parse the value text s[0..n) of var into v; nonzero with msg on error. */
static int parse_value(gm_fmu_values* v, const gm_fmu_variable* var, const char* s, size_t n, locale_t c_locale,
                       char* msg, size_t msg_size) {
  char text[64];
  if (var->type == GM_FMU_String) {
    char* out = malloc(n + 1);
    size_t k = 0, i = 1;
    if (!out) return snprintf(msg, msg_size, "out of memory"), 1;
    int closed = 0;
    for (; n && s[0] == '"' && i < n; i++) {
      unsigned char ch = (unsigned char)s[i];
      if (ch == '"') {
        closed = 1;
        i++;
        break;
      }
      if (ch < 0x20) break;
      if (ch == '\\') {
        if (i + 1 >= n || (s[i + 1] != '"' && s[i + 1] != '\\')) break;
        ch = (unsigned char)s[++i];
      }
      out[k++] = (char)ch;
    }
    if (!closed || i != n) {
      free(out);
      snprintf(msg, msg_size, "%s: a String value is written \"...\" with \\\" and \\\\ as the only escapes",
               var->name);
      return 1;
    }
    out[k] = '\0';
    values_set_string(v, var, out);
    return 0;
  }
  if (n == 0 || n >= sizeof text) {
    snprintf(msg, msg_size, "%s: missing or overlong value", var->name);
    return 1;
  }
  memcpy(text, s, n);
  text[n] = '\0';
  if (var->type == GM_FMU_Real) {
    char* end;
    double x = strtod_l(text, &end, c_locale);
    if (end != text + n || !isfinite(x)) {
      snprintf(msg, msg_size, "%s = %s: a Real is a finite decimal number ('.' as decimal separator)", var->name,
               text);
      return 1;
    }
    memcpy(field(v, var), &x, sizeof x);
    return 0;
  }
  int x;
  if (var->type == GM_FMU_Boolean) {
    if (strcmp(text, "true") != 0 && strcmp(text, "false") != 0) {
      snprintf(msg, msg_size, "%s = %s: a Boolean is true or false", var->name, text);
      return 1;
    }
    x = text[0] == 't';
  } else { /* Integer: digits only, so that no locale or base prefix is involved */
    const char* d = text + (text[0] == '-' || text[0] == '+');
    long long value = 0;
    int ok = *d != '\0';
    for (; ok && *d; d++) {
      ok = *d >= '0' && *d <= '9';
      value = value * 10 + (*d - '0');
      ok = ok && value <= (long long)INT_MAX + 1;
    }
    if (text[0] == '-') value = -value;
    if (!ok || value > INT_MAX || value < INT_MIN) {
      snprintf(msg, msg_size, "%s = %s: an Integer is a decimal number within 32 bits", var->name, text);
      return 1;
    }
    x = (int)value;
  }
  memcpy(field(v, var), &x, sizeof x);
  return 0;
}

static int is_blank(char ch) {
  return ch == ' ' || ch == '\t' || ch == '\r';
}

/* Parse the whole file text into v. */
static int parse_start_file(gm_fmu_values* v, const char* text, size_t size, int* count, char* msg,
                            size_t msg_size) {
  char what[400];
  unsigned char seen[N_VARIABLES] = {0};
  locale_t c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
  if (!c_locale) return snprintf(msg, msg_size, "out of memory"), 1;
  int line = 0, header = 0, failed = 0;
  const char* end = text + size;
  for (const char* s = text; s < end && !failed;) {
    const char* eol = memchr(s, '\n', (size_t)(end - s));
    if (!eol) eol = end;
    line++;
    const char* a = s;
    const char* b = eol;
    s = eol + 1;
    while (a < b && is_blank(*a)) a++;
    while (b > a && is_blank(b[-1])) b--;
    if (a == b || *a == '#') continue;
    if (!header) {
      static const char magic[] = "gearmesh-start-values 1";
      header = 1;
      if ((size_t)(b - a) != sizeof magic - 1 || memcmp(a, magic, sizeof magic - 1) != 0) {
        snprintf(what, sizeof what, "the first line must be \"%s\"", magic);
        failed = 1;
      }
      continue;
    }
    const char* name_end = a;
    while (name_end < b && !is_blank(*name_end)) name_end++;
    const gm_fmu_variable* var = variable_named(a, (size_t)(name_end - a));
    const char* value = name_end;
    while (value < b && is_blank(*value)) value++;
    if (!var) {
      snprintf(what, sizeof what, "%.*s: no variable of that name", (int)(name_end - a), a);
      failed = 1;
    } else if (var->causality != GM_FMU_parameter && var->causality != GM_FMU_input) {
      snprintf(what, sizeof what, "%s: only parameters and inputs have start values", var->name);
      failed = 1;
    } else if (seen[var - gm_fmu_variables]++) {
      snprintf(what, sizeof what, "%s: given twice", var->name);
      failed = 1;
    } else {
      failed = parse_value(v, var, value, (size_t)(b - value), c_locale, what, sizeof what);
      *count += !failed;
    }
  }
  freelocale(c_locale);
  if (!failed && !header) {
    snprintf(what, sizeof what, "empty file; the first line must be \"gearmesh-start-values 1\"");
    failed = 1;
  }
  if (failed) snprintf(msg, msg_size, "resources/" FMU_START_VALUES_FILE ":%d: %s", line, what);
  return failed;
}

int values_read_start_file(gm_fmu_values* start, const char* resources, int* count, char* msg, size_t msg_size) {
  *count = 0;
  if (!resources) return 0;
  size_t n = strlen(resources);
  char* path = malloc(n + sizeof FMU_START_VALUES_FILE);
  if (!path) return snprintf(msg, msg_size, "out of memory"), 1;
  memcpy(path, resources, n);
  memcpy(path + n, FMU_START_VALUES_FILE, sizeof FMU_START_VALUES_FILE);
  /* only a regular file: opening a FIFO would block fmi2Instantiate until a writer comes */
  struct stat st;
  if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
    free(path);
    snprintf(msg, msg_size, "resources/" FMU_START_VALUES_FILE ": not a regular file (mode 0%o); allowed: a "
             "regular file or none", (unsigned)st.st_mode);
    return 1;
  }
  FILE* f = fopen(path, "rb");
  int err = errno;
  free(path);
  if (!f) {
    if (err == ENOENT || err == ENOTDIR) return 0; /* not a scene FMU: the generic start values */
    char reason[128];
    snprintf(msg, msg_size, "resources/" FMU_START_VALUES_FILE ": cannot open: %s",
             error_text(err, reason, sizeof reason));
    return 1;
  }
  char* text = malloc(START_FILE_LIMIT + 1);
  size_t size = text ? fread(text, 1, START_FILE_LIMIT + 1, f) : 0;
  int read_error = ferror(f);
  fclose(f);
  if (!text || read_error || size > START_FILE_LIMIT) {
    free(text);
    snprintf(msg, msg_size, "resources/" FMU_START_VALUES_FILE ": %s",
             !text ? "out of memory" : read_error ? "cannot read the file" : "larger than 1 MiB");
    return 1;
  }
  gm_fmu_values v;
  int failed = values_copy(&v, start);
  if (failed) snprintf(msg, msg_size, "out of memory");
  else failed = parse_start_file(&v, text, size, count, msg, msg_size);
  free(text);
  if (failed) {
    values_free_strings(&v);
    *count = 0;
    return 1;
  }
  values_free_strings(start);
  *start = v;
  return 0;
}

/* ---- FMU state part ------------------------------------------------------------------------ */

static int stored(const gm_fmu_variable* var) {
  return var->causality != GM_FMU_calculatedParameter;
}

size_t values_state_size(const gm_fmu_values* v) {
  size_t n = sizeof(uint32_t);
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (!stored(var)) continue;
    n += var->type == GM_FMU_String ? sizeof(uint32_t) + strlen(values_get_string(v, var)) : value_size(var);
  }
  return n;
}

unsigned char* values_state_save(const gm_fmu_values* v, unsigned char* buf) {
  uint32_t count = N_VARIABLES;
  memcpy(buf, &count, sizeof count);
  buf += sizeof count;
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (!stored(var)) continue;
    if (var->type == GM_FMU_String) {
      const char* s = values_get_string(v, var);
      uint32_t length = (uint32_t)strlen(s); /* strings are short names; < 4 GiB */
      memcpy(buf, &length, sizeof length);
      memcpy(buf + sizeof length, s, length);
      buf += sizeof length + length;
    } else {
      memcpy(buf, field(v, var), value_size(var));
      buf += value_size(var);
    }
  }
  return buf;
}

int values_state_load(gm_fmu_values* v, const unsigned char** buf, const unsigned char* end, char* msg,
                      size_t msg_size) {
  const unsigned char* b = *buf;
  uint32_t count;
  if ((size_t)(end - b) < sizeof count) return snprintf(msg, msg_size, "FMU state is truncated"), 1;
  memcpy(&count, b, sizeof count);
  b += sizeof count;
  if (count != N_VARIABLES) {
    snprintf(msg, msg_size, "FMU state holds %u variables, this FMU has %u", (unsigned)count, (unsigned)N_VARIABLES);
    return 1;
  }
  for (size_t i = 0; i < N_VARIABLES; i++) {
    const gm_fmu_variable* var = &gm_fmu_variables[i];
    if (!stored(var)) continue;
    if (var->type != GM_FMU_String) {
      if ((size_t)(end - b) < value_size(var)) return snprintf(msg, msg_size, "FMU state is truncated"), 1;
      memcpy(field(v, var), b, value_size(var));
      b += value_size(var);
      continue;
    }
    uint32_t length;
    if ((size_t)(end - b) < sizeof length) return snprintf(msg, msg_size, "FMU state is truncated"), 1;
    memcpy(&length, b, sizeof length);
    b += sizeof length;
    if ((size_t)(end - b) < length) return snprintf(msg, msg_size, "FMU state is truncated"), 1;
    if (memchr(b, '\0', length)) return snprintf(msg, msg_size, "FMU state: %s holds a NUL byte", var->name), 1;
    char* s = copy_bytes((const char*)b, length);
    if (!s) return snprintf(msg, msg_size, "out of memory"), 1;
    values_set_string(v, var, s);
    b += length;
  }
  *buf = b;
  return 0;
}
