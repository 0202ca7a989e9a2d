"""Drive GearMesh.fmu through fmpy with legal FMI 2.0 call sequences only."""
from __future__ import annotations

import functools
import pathlib
import shutil
import tempfile
from ctypes import byref, c_char_p, c_int, c_size_t, c_void_p, create_string_buffer

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2Discard)
from fmpy import calloc, free


class FMUError(RuntimeError):
    """An FMI call failed; the message carries what the FMU logged. `discarded`: the call
    returned fmi2Discard (fmi2DoStep refused the step, e.g. a TE jump of a skipped tooth); the
    instance is still usable and its time did not advance."""

    def __init__(self, message: str, discarded: bool = False):
        super().__init__(message)
        self.discarded = discarded


@functools.lru_cache(maxsize=None)
def _unpacked(fmu_path: str) -> tuple[str, object]:
    """Extract an FMU once per process (removed at exit) and read its model description."""
    target = tempfile.mkdtemp(prefix="gearmesh-fmu-")
    import atexit

    atexit.register(shutil.rmtree, target, True)
    extract(fmu_path, target)
    return target, read_model_description(fmu_path)


class GearMeshFMU:
    """One FMU instance: parameters set before initialization, then inputs -> doStep -> outputs."""

    def __init__(self, fmu_path: pathlib.Path | str, parameters: dict | None = None,
                 instance_name: str = "gearmesh", start_time: float = 0.0, initialize: bool = True):
        unzip_dir, md = _unpacked(str(pathlib.Path(fmu_path).resolve()))
        self.model_description = md
        self.variables = {v.name: v for v in md.modelVariables}
        self.messages: list[str] = []
        self.failed = False  # an FMI call returned Error: only freeing is legal now
        self._callbacks = self._make_callbacks()
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip_dir,
                             modelIdentifier=md.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self.time = start_time
        self._call(self.fmu.instantiate, callbacks=self._callbacks)
        # Warnings (design warnings at initialization among them) are always wanted.
        self._call(self.fmu.setDebugLogging, True, ["logStatusWarning"])
        self._call(self.fmu.setupExperiment, startTime=start_time)
        self.set(parameters or {})
        self.initialized = initialize  # False: Instantiated, for check()
        if initialize:
            self._call(self.fmu.enterInitializationMode)
            self._call(self.fmu.exitInitializationMode)

    def check(self) -> str:
        """The core's check of the parameters and inputs set so far, without reading a file or
        building the model (the binary's gearmesh_check, the core's gm_model_check; docs/fmi.md,
        "Checking parameters"): "" if they pass, else the message initialization would give."""
        function = self.fmu.dll.gearmesh_check
        function.argtypes = [c_void_p, c_char_p, c_size_t]
        function.restype = c_int
        text = create_string_buffer(1024)
        function(self.fmu.component, text, len(text))
        return text.value.decode("utf-8", "replace")

    @property
    def warnings(self) -> list[str]:
        """Messages the FMU logged with status Warning."""
        return [m for m in self.messages if m.startswith("[logStatusWarning]")]

    def _make_callbacks(self) -> fmi2CallbackFunctions:
        def log(_env, _name, status, category, message):
            self.messages.append(f"[{category.decode()}] {message.decode('utf-8', 'replace')}")

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(log)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        from fmpy.logging import addLoggerProxy

        addLoggerProxy(byref(cb))
        return cb

    def _call(self, function, *args, **kwargs):
        try:
            return function(*args, **kwargs)
        except FMICallException as exc:
            discarded = exc.status == fmi2Discard
            self.failed = self.failed or not discarded
            detail = self.messages[-1] if self.messages else "no message logged"
            raise FMUError(f"{exc}: {detail}", discarded) from exc

    def set(self, values: dict) -> None:
        """Set variables by name (Real, Integer or Boolean)."""
        groups: dict[str, tuple[list, list]] = {}
        for name, value in values.items():
            if name not in self.variables:
                raise KeyError(f"{name}: no such FMU variable")
            var = self.variables[name]
            refs, vals = groups.setdefault(var.type, ([], []))
            refs.append(var.valueReference)
            vals.append(value)
        setters = {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger,
                   "Boolean": self.fmu.setBoolean, "String": self._set_strings}
        for kind, (refs, vals) in groups.items():
            self._call(setters[kind], refs, vals)

    def _set_strings(self, refs, values):
        # fmpy's setString encodes str itself (bytes would fail there)
        self.fmu.setString(refs, [v.decode("utf-8") if isinstance(v, bytes) else v for v in values])

    def get(self, names: list[str]) -> dict:
        """Values of the named variables."""
        getters = {"Real": self.fmu.getReal, "Integer": self.fmu.getInteger,
                   "Boolean": self.fmu.getBoolean, "String": self.fmu.getString}
        out = {}
        for name in names:
            var = self.variables[name]
            out[name] = self._call(getters[var.type], [var.valueReference])[0]
        return out

    def step(self, inputs: dict, h: float = 1e-3) -> None:
        """Hold `inputs` over [t, t + h] and advance; outputs are then those at t + h."""
        self.set(inputs)
        self._call(self.fmu.doStep, currentCommunicationPoint=self.time,
                   communicationStepSize=h)
        self.time += h

    def close(self) -> None:
        try:
            if not self.failed and self.initialized:
                self.fmu.terminate()
        finally:
            self.fmu.freeInstance()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
