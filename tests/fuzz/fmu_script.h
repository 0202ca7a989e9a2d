/* The input language of fuzz_fmu_calls (tests/fuzz/fuzz_fmu_calls.c): what each byte means, shared
 * with the seed writer (tests/fuzz/make_fmu_seeds.c). Read with fuzz_bytes.h: "u8" one byte,
 * "real" fuzz_real, "int" fuzz_int, "vr:T" a value reference (a byte < 240 picks the byte-th
 * variable of type T modulo their count; 240..249 value references around the end of the table,
 * the last ones invalid; 250..255 four raw bytes), "chunk" a length byte and that many bytes.
 *
 * Prologue (the instance):
 *   u8 resource form (RES_*), then for RES_RAW a chunk (the URI's bytes)
 *   u8 start values file: 0 none, 1 a chunk as its contents, 2 a valid file (the defaults, named)
 *   u8 flags: bit 0 loggingOn, bit 1 wrong GUID, bit 2 no logger, bit 3 empty instance name
 *   chunk: the contents of resources/fuzz.bin (a String parameter may name it)
 * Then calls until the input ends: u8 opcode (modulo OP_COUNT) and its arguments below. The
 * instance, every FMU state and every buffer is freed at the end. */
#ifndef GEARMESH_FUZZ_FMU_SCRIPT_H
#define GEARMESH_FUZZ_FMU_SCRIPT_H

/* fmuResourceLocation forms, of the per-process directory holding resources/ */
enum {
  RES_NONE,       /* NULL */
  RES_FILE3,      /* file:///dir/resources/ */
  RES_FILE1,      /* file:/dir/resources (no trailing slash) */
  RES_LOCALHOST,  /* file://localhost/dir/resources/ */
  RES_PERCENT,    /* file:// + every byte of the path but '/' percent-encoded, mixed case */
  RES_RAW,        /* a chunk of raw bytes */
  RES_OTHER_HOST, /* file://elsewhere/dir/resources/ */
  RES_HTTP,       /* http://localhost/resources/ */
  RES_EMPTY,      /* "" */
  RES_COUNT
};

enum {
  OP_SETUP,          /* u8 flags (bit 0 toleranceDefined, bit 1 stopTimeDefined), real tolerance, real start, real stop */
  OP_ENTER_INIT,     /* - */
  OP_EXIT_INIT,      /* - */
  OP_SET_REAL,       /* u8 n (1 + n % 4), n x (vr:Real, real) */
  OP_SET_INTEGER,    /* u8 n, n x (vr:Integer, int) */
  OP_SET_BOOLEAN,    /* u8 n, n x (vr:Boolean, int) */
  OP_SET_STRING,     /* u8 n, n x (vr:String, u8 value: STRING_VALUES index, or a chunk if beyond) */
  OP_GET_REAL,       /* u8 n, n x vr:Real */
  OP_GET_INTEGER,    /* u8 n, n x vr:Integer */
  OP_GET_BOOLEAN,    /* u8 n, n x vr:Boolean */
  OP_GET_STRING,     /* u8 n, n x vr:String */
  OP_DO_STEP,        /* u8 form (0 tc = the FMU's time, 1 tc = real, 2 the FMU's time + real), [real], real h */
  OP_GET_STATE,      /* u8 slot (of 2) */
  OP_SET_STATE,      /* u8 slot */
  OP_FREE_STATE,     /* u8 slot */
  OP_SERIALIZE,      /* u8 slot, u8 buffer (0 exact, 1 one byte short), then a state mutation (below) and
                        fmi2DeSerializeFMUstate into the slot */
  OP_DESERIALIZE,    /* u8 slot, chunk payload: a blob with a valid header and checksum around it */
  OP_DERIVATIVE,     /* u8 nUnknown (% 5), u8 nKnown (% 5), nUnknown x vr:Real, nKnown x (vr:Real, real) */
  OP_RESET,          /* - */
  OP_TERMINATE,      /* - */
  OP_STATUS,         /* u8 which (% 5: Status, Real, Integer, Boolean, String), u8 kind (% 6) */
  OP_DEBUG_LOGGING,  /* u8 loggingOn, u8 n (% 4), n x u8 category (CATEGORY_NAMES index, or NULL beyond) */
  OP_UNSUPPORTED,    /* u8 which (% 3: SetRealInputDerivatives, GetRealOutputDerivatives, CancelStep) */
  OP_REINSTANTIATE,  /* the prologue again: the instance is freed and a new one made */
  OP_COUNT
};

/* State mutation after OP_SERIALIZE: u8 count (% 4) of (u32 position, u8 xor), then u8 length
 * change (0 none, 1 one byte less, 2 one byte more), then u8 restamp (odd: the checksum is
 * recomputed, so the checks behind it are reached). */

/* Values OP_SET_STRING picks from (the files exist in resources/ unless named missing). */
#define STRING_VALUES(S)                                                                         \
  S("") S("deviations.txt") S("stiffness.txt") S("te.txt") S("set_a.gcdb") S("fuzz.bin")       \
  S("missing.txt") S("../resources/te.txt") S("/etc/passwd") S("folder") S("fifo") S("a\\b")   \
  S("folder/") S("./te.txt") S("\xff\xfe") S("te.txt/..")
#define CATEGORY_NAMES(C) \
  C("logEvents") C("logStatusWarning") C("logStatusError") C("logStatusFatal") C("logAll") C("contact") C("solver") C("bogus")

#endif /* GEARMESH_FUZZ_FMU_SCRIPT_H */
