"""FMPy (the venv's) as the reference master of the cases in a JSON file
(tests/python/test_masters.py): python run_fmpy.py CASES.json OUT.json, or run_case(case).
Each case: the GearMesh FMU and the Ramps FMU stepped together at a fixed communication step,
Jacobi style as libcosim's and Maestro's fixed-step algorithms do: at each communication point t
the Ramps outputs at t go to GearMesh's inputs, then both step from t to t + h. The parameters are
set before initialization, the ramps' values at the start in Initialization Mode. Output: the
listed GearMesh outputs after every step, {"time": [...], output: [...]}, or {"error": ...}."""
import json
import sys

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave


class Slave:
    def __init__(self, path, name):
        self.md = read_model_description(path)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.messages = []

        def log(_env, _name, status, category, message):
            self.messages.append(f"[{category.decode()}] {message.decode('utf-8', 'replace')}")

        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=extract(path),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=False)
        self.fmu.setupExperiment(startTime=0.0)

    def set(self, values):
        for name, (kind, value) in values.items():
            setter = {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger, "Boolean": self.fmu.setBoolean}[kind]
            setter([self.vars[name].valueReference], [value])

    def get(self, names):
        return self.fmu.getReal([self.vars[n].valueReference for n in names])

    def free(self):
        self.fmu.freeInstance()


def run_case(case):
    gm, ramps = Slave(case["fmu"], "gearmesh"), Slave(case["ramps"], "ramps")
    sources = [s for s, _ in case["connections"]]
    targets = {t: ("Real", None) for _, t in case["connections"]}
    out = {"time": [], **{name: [] for name in case["outputs"]}}
    try:
        gm.set(case["parameters"])
        ramps.set({k: ("Real", v) for k, v in case["ramp_parameters"].items()})
        for s in (gm, ramps):
            s.fmu.enterInitializationMode()

        def transfer():
            gm.set({t: ("Real", v) for t, v in zip(targets, ramps.get(sources))})

        transfer()
        for s in (gm, ramps):
            s.fmu.exitInitializationMode()
        h = case["step"]
        for k in range(round(case["stop"] / h)):
            t = k * h
            transfer()
            for s in (gm, ramps):
                s.fmu.doStep(t, h)
            out["time"].append((k + 1) * h)
            for name, value in zip(case["outputs"], gm.get(case["outputs"])):
                out[name].append(value)
        return out
    except FMICallException as exc:
        return {"error": f"{exc}: {' '.join(gm.messages[-3:])}", **out}
    finally:
        gm.free(), ramps.free()


def main():
    cases = json.loads(open(sys.argv[1]).read())
    with open(sys.argv[2], "w") as f:
        json.dump({case["name"]: run_case(case) for case in cases["cases"]}, f)


if __name__ == "__main__":
    main()
