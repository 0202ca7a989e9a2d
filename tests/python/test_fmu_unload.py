"""An importer may unload the FMU's library (dlclose) long before its process ends, as FMPy's
freeLibrary does. Nothing the library leaves behind may then run at exit: a static object with a
destructor, registered on first use, would be called from exit() into unloaded code (the process
dies with SIGSEGV after it has done all its work). The case: level 4's coupled solve capped at one
iteration (solver.max_iterations = 1), which builds the message naming the parameter, then the
instance freed and the library unloaded, in a child process whose exit status is checked.

The build here links the system's libstdc++, whose registration runs such destructors at
dlclose, so this FMU passes either way; the Zig-built binaries of the wheel and the multi-platform
FMU (libc++) register them for exit, and crashed there (tests/python/test_platforms.py runs the
same case on the multi-platform FMU)."""

import subprocess
import sys
import textwrap

CHILD = textwrap.dedent("""
    import sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    fmu = sys.argv[1]
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="unload")
    slave.instantiate(loggingOn=True)  # FMPy's default logger prints the FMU's messages
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["solver.max_iterations"]], [1])
    slave.setReal([vr["gear2.phi"]], [0.004])  # wound up: one iteration cannot converge the contact
    try:
        slave.exitInitializationMode()
        print("initialized")
    except Exception:
        print("refused")
    slave.freeInstance()
    slave.freeLibrary()
    sys.stdout.flush()
""")


def check_unload(fmu) -> None:
    """The case on `fmu`: the child exits with status 0 after producing the message."""
    done = subprocess.run([sys.executable, "-c", CHILD, str(fmu)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"exit status {done.returncode}\n{done.stdout}\n{done.stderr}"
    # the message that builds the static text was produced: the case exercises it
    assert "solver.max_iterations" in done.stdout, done.stdout


def test_the_library_leaves_nothing_to_run_at_exit(fmu_path):
    check_unload(fmu_path)
