/* File URI decoding for the resource location (RFC 8089 forms that FMI importers send). */
#include "uri.h"

#include <stdlib.h>
#include <string.h>

/* Case-insensitive prefix test without the locale (tolower depends on it). */
static int has_prefix(const char* s, const char* prefix) {
  for (; *prefix; s++, prefix++) {
    char c = *s;
    if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
    if (c != *prefix) return 0;
  }
  return 1;
}

static int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

char* fmu_uri_to_path(const char* uri) {
  if (!uri || !has_prefix(uri, "file:")) return NULL;
  const char* path = uri + 5;
  if (path[0] == '/' && path[1] == '/') { /* authority: empty or localhost */
    const char* authority = path + 2;
    path = strchr(authority, '/');
    if (!path) return NULL;
    size_t n = (size_t)(path - authority);
    if (n != 0 && !(n == 9 && has_prefix(authority, "localhost"))) return NULL;
  }
  if (path[0] != '/') return NULL; /* relative paths are not resource locations */

  size_t len = strlen(path);
  char* out = malloc(len + 2); /* decoding never grows the string; +1 for a trailing '/' */
  if (!out) return NULL;
  size_t n = 0;
  for (const char* s = path; *s; s++) {
    if (*s == '%') {
      int hi = hex_value(s[1]), lo = hi < 0 ? -1 : hex_value(s[2]);
      if (lo < 0 || (hi == 0 && lo == 0)) {
        free(out);
        return NULL;
      }
      out[n++] = (char)(hi * 16 + lo);
      s += 2;
    } else {
      out[n++] = *s;
    }
  }
  if (out[n - 1] != '/') out[n++] = '/';
  out[n] = '\0';
#ifdef _WIN32
  /* file:///C:/dir/ names C:/dir/ on Windows: the drive letter follows the root's '/' */
  char drive = (char)(out[1] | 0x20);
  if (n >= 3 && drive >= 'a' && drive <= 'z' && out[2] == ':') memmove(out, out + 1, n);
#endif
  return out;
}
