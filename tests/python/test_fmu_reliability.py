"""Reliability of GearMesh.fmu against corrupted or hostile input (docs/reliability.md): FMU state
blobs with a checksum, log messages that are valid UTF-8, a time that never runs backwards, and
resource files that must be regular files. Each test fails on the behaviour before these checks
(state format 2: most single-bit flips accepted; raw bytes echoed to the logger; h = inf
accepted; a FIFO named as a resource blocking fmi2ExitInitializationMode)."""
from __future__ import annotations

import itertools
import os
import struct
import threading
import time
from ctypes import POINTER, byref, c_double, c_size_t, c_ubyte, cast, create_string_buffer

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2CoSimulation,
    fmi2Error,
    fmi2FMUstate,
    fmi2LastSuccessfulTime,
    fmi2String,
    fmi2ValueReference,
)
from fmpy.logging import addLoggerProxy

from test_fmu_conformance import H, assert_error, drive, run

# ---- a logger that keeps the raw bytes of every message ---------------------------------------

_raw: dict[int, list] = {}
_keys = itertools.count(1_000_000)  # apart from test_fmu_conformance's keys


@fmi2CallbackLoggerTYPE
def _route_raw(env, name, status, category, message):
    _raw.setdefault(env or 0, []).append((status, category, bytes(message)))


class RawLog:
    """Callbacks whose logger records (status, category, message bytes), undecoded."""

    def __init__(self):
        self.key = next(_keys)
        self.records = _raw.setdefault(self.key, [])
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = _route_raw
        self.callbacks.componentEnvironment = self.key
        addLoggerProxy(byref(self.callbacks))

    def errors(self) -> list[bytes]:
        return [m for s, c, m in self.records if c == b"logStatusError"]


def raw_instance(new, logging_on=False, resources_uri=None, md=None, expect_ok=True):
    """An instance of the generic FMU whose log is a RawLog (inst.raw)."""
    inst = new(instantiate=False)
    inst.raw = RawLog()
    uri = resources_uri if resources_uri is not None else (inst.slave.unzipDirectory + "/resources").replace(
        "//", "/")
    uri = uri if uri.startswith("file:") else "file://" + uri
    c = inst.slave.fmi2Instantiate(b"rel", fmi2CoSimulation, inst.md.guid.encode(), uri.encode(),
                                   byref(inst.raw.callbacks), 0, 1 if logging_on else 0)
    assert (c is not None) == expect_ok, [m for *_, m in inst.raw.records]
    inst.slave.component = c
    return inst


def fnv1a64(data: bytes) -> int:
    h = 14695981039346656037
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


HEADER = 8 + 4 + 40 + 8 + 8  # magic, format, GUID, payload size, checksum
CHECKSUM_AT = 8 + 4 + 40 + 8


def with_checksum(blob: bytes) -> bytes:
    """The blob with its checksum field recomputed (format 3)."""
    body = blob[:CHECKSUM_AT] + blob[CHECKSUM_AT + 8:]
    return blob[:CHECKSUM_AT] + struct.pack("<Q", fnv1a64(body)) + blob[CHECKSUM_AT + 8:]


def deserialize_status(inst, blob: bytes) -> int:
    """fmi2DeSerializeFMUstate's status for blob (a successful state is freed again)."""
    state = fmi2FMUstate()
    buffer = create_string_buffer(blob, size=len(blob))
    try:  # fmpy's wrapper raises on fmi2Error and above
        inst.slave.fmi2DeSerializeFMUstate(inst.slave.component, buffer, c_size_t(len(blob)), byref(state))
        status = 0
    except FMICallException as exc:
        status = exc.status
    if state:
        inst.slave.fmi2FreeFMUstate(inst.slave.component, byref(state))
    return status


FRICTION = {"model.friction_coefficient": 0.3}  # contact memory (slip direction) in the state


def loaded_blob(inst, steps=6):
    """Initialize with friction, take `steps` loaded steps; the serialized state there."""
    inst.initialize(FRICTION)
    run(inst, steps)
    state = inst.slave.getFMUstate()
    blob = inst.slave.serializeFMUstate(state)
    inst.slave.freeFMUstate(state)
    return bytes(blob)


# ---- 1. state blobs: version and checksum -----------------------------------------------------

def test_state_header_is_format_3_with_a_checksum(new):
    inst = raw_instance(new)
    blob = loaded_blob(inst)
    assert blob[:8] == b"GearMesh"
    assert struct.unpack_from("<I", blob, 8)[0] == 3
    assert struct.unpack_from("<Q", blob, 52)[0] == len(blob) - HEADER
    assert with_checksum(blob) == blob  # 64-bit FNV-1a over everything but the checksum field


def test_every_single_bit_flip_of_a_state_is_refused(new):
    """Flip every bit of a loaded state with friction memory, one at a time: each is refused by
    fmi2DeSerializeFMUstate with fmi2Error and one message (valid UTF-8); the instance then
    restores the good blob and steps exactly as a reference run from that state."""
    inst = raw_instance(new)
    blob = loaded_blob(inst)
    reference = run(inst, 4, t0=6 * H)
    refused = 0
    before = len(inst.raw.errors())
    started = time.perf_counter()
    for byte in range(len(blob)):
        for bit in range(8):
            bad = bytearray(blob)
            bad[byte] ^= 1 << bit
            status = deserialize_status(inst, bytes(bad))
            assert status == fmi2Error, (byte, bit)
            refused += 1
    seconds = time.perf_counter() - started
    errors = inst.raw.errors()[before:]
    assert refused == 8 * len(blob) == len(errors)
    for message in errors:
        text = message.decode("utf-8")  # strict: raises on invalid UTF-8
        assert "fmi2DeSerializeFMUstate" in text
    # the checksum catches every flip the older checks let through
    assert sum(b"checksum" in m for m in errors) > 0.9 * refused
    print(f"\n{refused} single-bit flips of a {len(blob)}-byte state, all refused, in {seconds:.2f} s")
    # fmpy's wrapper raises on the refusal too
    bad = bytearray(blob)
    bad[len(blob) // 2] ^= 4
    assert_error(inst.slave.deSerializeFMUstate, bytes(bad))
    # the instance still works: the good blob restores the state of the reference run
    state = inst.slave.deSerializeFMUstate(blob)
    inst.slave.setFMUstate(state)
    inst.slave.freeFMUstate(state)
    assert run(inst, 4, t0=6 * H) == reference


def test_set_state_checks_the_checksum_too(new):
    """A state whose bytes changed in memory after fmi2GetFMUstate (a stray write) is refused by
    fmi2SetFMUstate before anything is applied."""
    inst = raw_instance(new)
    inst.initialize(FRICTION)
    run(inst, 6)
    state = inst.slave.getFMUstate()
    reference = run(inst, 3, t0=6 * H)
    size = c_size_t()
    inst.slave.fmi2SerializedFMUstateSize(inst.slave.component, state, byref(size))
    # an fmi2FMUstate of this FMU is {size_t size; bytes[]}: flip bits in place
    raw = cast(state, POINTER(c_ubyte * (8 + size.value))).contents
    for offset in (8 + 30, 8 + HEADER + 3, 8 + size.value - 1, 8 + size.value // 2):
        raw[offset] ^= 0x10
        assert_error(inst.slave.setFMUstate, state)
        assert b"checksum" in inst.raw.errors()[-1]
        assert run(inst, 1, t0=9 * H)  # the instance is unchanged and steps on
        raw[offset] ^= 0x10
        inst.slave.setFMUstate(state)  # intact again
        assert run(inst, 3, t0=6 * H) == reference
        inst.slave.setFMUstate(state)
        run(inst, 3, t0=6 * H)
    inst.slave.freeFMUstate(state)


def test_a_format_2_blob_is_refused_naming_the_formats(new):
    inst = raw_instance(new)
    blob = bytearray(loaded_blob(inst))
    blob[8:12] = struct.pack("<I", 2)
    assert deserialize_status(inst, bytes(blob)) == fmi2Error
    assert b"FMU state format 2, this FMU reads format 3" in inst.raw.errors()[-1]


# ---- 2. log messages are valid UTF-8 ----------------------------------------------------------

def test_garbage_guid_in_a_state_is_logged_as_valid_utf8(new):
    """A state with an intact checksum but a GUID of non-UTF-8 bytes (another build's, or made
    up): refused as from another build, the bytes escaped as \\xNN in the message."""
    inst = raw_instance(new)
    blob = bytearray(loaded_blob(inst))
    blob[12:12 + 40] = bytes([0xFF, 0xFE, 0x80, 0xC3, 0x28, 0x1B, 0x7F, 0xE2, 0x28, 0xA1]) + b"\x9f" * 30
    assert deserialize_status(inst, with_checksum(bytes(blob))) == fmi2Error
    message = inst.raw.errors()[-1]
    text = message.decode("utf-8")  # strict
    assert "from another GearMesh build" in text
    assert "\\xFF\\xFE\\x80\\xC3(\\x1B\\x7F\\xE2(\\xA1\\x9F" in text, text


def set_raw_string(inst, name: str, value: bytes) -> None:
    """fmi2SetString with bytes as they are (fmpy's setString encodes str)."""
    vr = (fmi2ValueReference * 1)(inst.vr(name))
    inst.slave.fmi2SetString(inst.slave.component, vr, c_size_t(1), (fmi2String * 1)(value))


def test_non_utf8_file_name_is_logged_as_valid_utf8(new, tmp_path):
    """A String parameter of raw bytes reaches the messages of the FMU layer and of the core
    (the file's path); every one that reaches the logger is valid UTF-8."""
    inst = raw_instance(new, logging_on=True, resources_uri=tmp_path.as_uri())
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    set_raw_string(inst, "model.te_table", b"caf\xe9\x01.txt")
    assert_error(inst.slave.exitInitializationMode)
    assert inst.raw.records
    for _, _, message in inst.raw.records:
        message.decode("utf-8")
    assert b"caf\\xE9\\x01.txt" in inst.raw.errors()[-1]
    # valid UTF-8 passes unchanged
    set_raw_string(inst, "model.te_table", "zahnrad-\u00fcbersetzung.txt".encode())
    assert_error(inst.slave.exitInitializationMode)
    assert "zahnrad-\u00fcbersetzung.txt".encode() in inst.raw.errors()[-1]


# ---- 3. time never runs backwards -------------------------------------------------------------

def last_time(inst) -> float:
    t = c_double()
    inst.slave.fmi2GetRealStatus(inst.slave.component, fmi2LastSuccessfulTime, byref(t))
    return t.value


@pytest.mark.parametrize("tc, h, words", [
    (2 * H, float("inf"), ["communicationStepSize = inf", "finite and > 0"]),
    (2 * H, float("nan"), ["communicationStepSize = nan", "finite and > 0"]),
    (2 * H, -float("inf"), ["communicationStepSize = -inf", "finite and > 0"]),
    (2 * H, 1e-30, ["ends at 2e-05 s", "a finite end later than t"]),  # tc + h rounds to tc
    (float("inf"), H, ["currentCommunicationPoint = inf", "the FMU is at t = 2"]),
    (float("nan"), H, ["currentCommunicationPoint = nan"]),
    (0.0, 1e-3, ["currentCommunicationPoint = 0 s", "the FMU is at t = 2"]),  # back in time
    (2 * H + 1e-10, H, ["currentCommunicationPoint = 2.0000"]),  # 5e-6 relative off: not rounding
])
def test_bad_steps_are_refused_and_time_stays(new, tc, h, words):
    inst = raw_instance(new)
    inst.initialize()
    run(inst, 2)
    outputs = inst.outputs()
    assert_error(inst.slave.doStep, tc, h)
    message = inst.raw.errors()[-1].decode()
    for w in words:
        assert w in message, message
    assert last_time(inst) == 2 * H and inst.outputs() == outputs
    assert_error(inst.slave.doStep, 0.0, 1e-3)  # never back to an earlier time
    run(inst, 2, t0=2 * H)  # the instance goes on from its own time
    assert last_time(inst) == 4 * H


def start_at(inst, t0: float) -> None:
    """Initialized at start time t0 with the inputs of drive(0) (the time only labels)."""
    inst.slave.setupExperiment(startTime=t0)
    inst.slave.enterInitializationMode()
    inst.set(drive(0.0))
    inst.slave.exitInitializationMode()


def test_huge_time_cannot_overflow_to_inf(new):
    """Near the largest double a step whose end overflows is refused; time stays finite."""
    inst = raw_instance(new)
    start_at(inst, 1e308)
    assert_error(inst.slave.doStep, 1e308, 1e308)
    assert "ends at inf" in inst.raw.errors()[-1].decode()
    inst.slave.doStep(1e308, 1e300)
    assert last_time(inst) == 1e308 + 1e300


def test_a_step_that_would_end_before_the_fmu_time_is_refused(new):
    """tc within the rounding tolerance below the FMU's time with a step shorter than the gap:
    the end would be before the FMU's time. Refused; the master's rounding stays allowed."""
    inst = raw_instance(new)
    start_at(inst, 1.0)
    assert_error(inst.slave.doStep, 1.0 - 5e-10, 1e-10)
    assert "finite end later than t" in inst.raw.errors()[-1].decode()
    inst.slave.doStep(1.0 - 4e-16, H)  # an ulp-sized rounding of the master is fine
    assert last_time(inst) == 1.0 - 4e-16 + H


def test_restored_state_sets_the_communication_point(new):
    """After fmi2SetFMUstate the FMU's time is the state's: steps continue from there (FMI 2.0's
    exception), and the later time is refused."""
    inst = raw_instance(new)
    inst.initialize()
    run(inst, 2)
    state = inst.slave.getFMUstate()
    run(inst, 3, t0=2 * H)
    inst.slave.setFMUstate(state)
    inst.slave.freeFMUstate(state)
    assert_error(inst.slave.doStep, 5 * H, H)
    run(inst, 1, t0=2 * H)
    assert last_time(inst) == 3 * H


# ---- 4. resources must be regular files -------------------------------------------------------

RESOURCE_PARAMETERS = ["gear1.deviations", "gear2.deviations", "gear1.compliance", "gear2.compliance",
                       "model.stiffness_table", "model.te_table"]


class FifoWatchdog:
    """Watches a FIFO for a reader, from the start: keeps opening it for writing without blocking,
    which succeeds only while some process has it open for reading (else ENXIO), and closes it
    again, which ends a reader blocked in open() (old behaviour) instead of letting the test hang
    forever. `fired`: a reader was found. The poll's pace decides how soon, never whether: a
    blocked reader stays until found, and no clock can fire the watchdog on a slow machine."""

    def __init__(self, path):
        self.path = path
        self.done = threading.Event()
        self.fired = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while True:
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader
                pass
            else:
                self.fired = True
                os.close(fd)
            if self.done.wait(0.01):
                return

    def stop(self):
        self.done.set()
        self.thread.join()


@pytest.mark.parametrize("parameter", RESOURCE_PARAMETERS)
def test_fifo_named_as_resource_is_refused(new, tmp_path, parameter):
    fifo = tmp_path / "table.fifo"
    os.mkfifo(fifo)
    (tmp_path / "folder").mkdir()
    inst = raw_instance(new, resources_uri=tmp_path.as_uri())
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({parameter: "table.fifo"})
    inst.slave.enterInitializationMode()
    inst.set(drive(0.0))
    dog = FifoWatchdog(fifo)
    try:
        assert_error(inst.slave.exitInitializationMode)
    finally:
        dog.stop()
    assert not dog.fired, "fmi2ExitInitializationMode opened the FIFO (and blocked on it)"
    message = inst.raw.errors()[-1].decode()
    assert f'{parameter} = "table.fifo" is a FIFO (named pipe)' in message, message
    assert "regular file" in message
    # a directory is refused the same way, and the value can be corrected
    inst.set({parameter: "folder"})
    assert_error(inst.slave.exitInitializationMode)
    assert f'{parameter} = "folder" is a directory' in inst.raw.errors()[-1].decode()
    inst.set({parameter: ""})
    inst.slave.exitInitializationMode()


def test_fifo_as_start_values_file_is_refused_at_instantiation(new, tmp_path):
    fifo = tmp_path / "gearmesh-start-values.txt"
    os.mkfifo(fifo)
    dog = FifoWatchdog(fifo)
    try:
        inst = raw_instance(new, resources_uri=tmp_path.as_uri(), expect_ok=False)
    finally:
        dog.stop()
    assert not dog.fired, "fmi2Instantiate opened the FIFO (and blocked on it)"
    assert b"gearmesh-start-values.txt: not a regular file" in inst.raw.errors()[-1]
