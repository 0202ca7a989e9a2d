/* The fuzz targets' input reader (tests/fuzz/): bytes consumed front to back, so that a seed
 * can be written as a plain sequence (tests/fuzz/make_fmu_seeds.c) and every input, however
 * short, decodes to something (an exhausted input reads as zeros). C and C++. */
#ifndef GEARMESH_FUZZ_BYTES_H
#define GEARMESH_FUZZ_BYTES_H

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef struct fuzz_bytes {
  const uint8_t* data;
  size_t size, pos;
} fuzz_bytes;

static inline int fuzz_left(const fuzz_bytes* in) { return in->pos < in->size; }

static inline unsigned fuzz_u8(fuzz_bytes* in) { return fuzz_left(in) ? in->data[in->pos++] : 0u; }

static inline uint32_t fuzz_u32(fuzz_bytes* in) {
  uint32_t v = 0;
  for (int i = 0; i < 4; i++) v |= (uint32_t)fuzz_u8(in) << (8 * i);
  return v;
}

/* A choice in [0, n). */
static inline unsigned fuzz_pick(fuzz_bytes* in, unsigned n) { return n ? fuzz_u8(in) % n : 0u; }

/* Up to max bytes: a length byte, then that many bytes (fewer at the input's end). */
static inline size_t fuzz_chunk(fuzz_bytes* in, size_t max, const uint8_t** out) {
  size_t n = fuzz_u8(in);
  if (n > max) n = max;
  if (n > in->size - in->pos) n = in->size - in->pos;
  *out = in->data + in->pos;
  in->pos += n;
  return n;
}

/* Values that break numeric code: signed zeros, NaN, infinities, the extremes of a double,
 * denormals, and the edges of GearMesh's own ranges (|phi| <= 1e7 rad, |tilt| <= 0.02 rad). */
#define FUZZ_SPECIAL_REALS 32
static inline double fuzz_special_real(unsigned k) {
  static const double table[FUZZ_SPECIAL_REALS] = {
      0.0, -0.0, 1.0, -1.0, 0.5, NAN, -NAN, INFINITY, -INFINITY, DBL_MAX, -DBL_MAX, 1e308,
      DBL_MIN, -DBL_MIN, 4.9406564584124654e-324, -4.9406564584124654e-324, 1e-300, 1e-15, 1e-9,
      1e-6, 5e-6, 1e-5, 1e-4, 1e-3, 0.02, 0.0200001, 0.1, 1e3, 1e7, 10000000.000000002, 1e15,
      9.2233720368547758e18};
  return table[k % FUZZ_SPECIAL_REALS];
}

/* A double: tag byte < 32 a special value; < 224 a signed byte times 10^(tag % 24 - 16), so
 * from 1e-16 to 1.27e9 (small poses and steps included); else 8 raw bytes. */
static inline double fuzz_real(fuzz_bytes* in) {
  unsigned tag = fuzz_u8(in);
  if (tag < FUZZ_SPECIAL_REALS) return fuzz_special_real(tag);
  if (tag < 224) return (double)(int8_t)fuzz_u8(in) * pow(10.0, (double)((int)(tag % 24) - 16));
  uint64_t bits = fuzz_u32(in);
  bits |= (uint64_t)fuzz_u32(in) << 32;
  double v;
  memcpy(&v, &bits, sizeof v);
  return v;
}

/* An int: tag byte < 16 an edge value, < 224 the signed byte itself, else 4 raw bytes. */
static inline int fuzz_int(fuzz_bytes* in) {
  static const int table[16] = {0, 1, -1, 2, 3, 5, 10, 57, 200, 201, 10001, INT32_MAX, INT32_MIN,
                                INT32_MAX - 1, -2, 1000};
  unsigned tag = fuzz_u8(in);
  if (tag < 16) return table[tag];
  if (tag < 224) return (int)(int8_t)fuzz_u8(in);
  return (int)fuzz_u32(in);
}

#endif /* GEARMESH_FUZZ_BYTES_H */
