/* Resource location (FMI 2.0 fmuResourceLocation) to a local directory path. */
#ifndef GEARMESH_FMU_URI_H
#define GEARMESH_FMU_URI_H

/* The local directory named by a file URI, with one trailing '/', in a malloc'd string the
 * caller frees; NULL if uri is NULL or not a local file URI. Accepts file:///p, file:/p and
 * file://localhost/p, with or without a trailing slash, percent-encoded (%20, UTF-8 bytes,
 * %23, %25; hex digits in either case). Rejects other hosts, malformed or NUL escapes. */
char* fmu_uri_to_path(const char* uri);

#endif /* GEARMESH_FMU_URI_H */
