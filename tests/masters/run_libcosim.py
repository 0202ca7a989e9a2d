"""libcosim (PyPI libcosimpy) as the master of the cases in a JSON file (tests/python/test_masters.py):
    python run_libcosim.py CASES.json OUT.json
run with libcosimpy on PYTHONPATH (the test installs it into the platform cache). Each case: the
GearMesh FMU and the Ramps FMU as two local slaves of a fixed-step execution (libcosim's fixed
step algorithm: every slave steps from t to t + h, then the outputs go to the connected inputs),
the parameters as initial values, the ramps connected to GearMesh's inputs; the outputs read
after every step by a last-value observer. OUT.json: {case: {"time": [...], output: [...]}} or
{case: {"error": message}}."""
import json
import sys

from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave
from libcosimpy._internal import get_last_error_message

NS = 1_000_000_000  # libcosim's time unit: 1 ns


def variables(execution, index):
    return {v.name.decode(): v.reference for v in execution.slave_variables(index)}


def run(case):
    execution = CosimExecution.from_step_size(round(case["step"] * NS))
    gm = execution.add_local_slave(CosimLocalSlave(fmu_path=case["fmu"], instance_name="gearmesh"))
    ramps = execution.add_local_slave(CosimLocalSlave(fmu_path=case["ramps"], instance_name="ramps"))
    if gm < 0 or ramps < 0:
        return {"error": get_last_error_message()}
    gm_vr, ramps_vr = variables(execution, gm), variables(execution, ramps)
    setters = {"Real": execution.real_initial_value, "Integer": execution.integer_initial_value,
               "Boolean": execution.boolean_initial_value}
    for name, (kind, value) in case["parameters"].items():
        if not setters[kind](gm, gm_vr[name], {"Real": float, "Integer": int, "Boolean": bool}[kind](value)):
            return {"error": f"initial value {name}: {get_last_error_message()}"}
    for name, value in case["ramp_parameters"].items():
        execution.real_initial_value(ramps, ramps_vr[name], float(value))
    for source, target in case["connections"]:
        if execution.connect_real_variables(ramps, ramps_vr[source], gm, gm_vr[target]) != 0:
            return {"error": f"connect {source} -> {target}: {get_last_error_message()}"}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    refs = [gm_vr[name] for name in case["outputs"]]
    out = {"time": [], **{name: [] for name in case["outputs"]}}
    steps = round(case["stop"] / case["step"])
    for k in range(steps):
        if not execution.step():
            return {"error": f"step {k + 1} (t = {k * case['step']:g} s): {get_last_error_message()}", **out}
        out["time"].append(execution.status().current_time / NS)
        for name, value in zip(case["outputs"], observer.last_real_values(gm, refs)):
            out[name].append(value)
    return out


def main():
    cases = json.loads(open(sys.argv[1]).read())
    log_output_level(CosimLogLevel[cases.get("log_level", "WARNING")])
    results = {case["name"]: run(case) for case in cases["cases"]}
    with open(sys.argv[2], "w") as f:
        json.dump(results, f)


if __name__ == "__main__":
    main()
