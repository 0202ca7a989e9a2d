"""The main job's section of a train scene: its FMU (gearmesh.train_fmu) run as a system
simulator would, at the scene's [run] step (default 1e-2 s): every port's far end ramped from
rest to port_speed_rpm and the load on load_body ramped to load_Nm against its turning, for
duration_s. Reported: each body's mean speed and its ratio to the port's, each mesh's mean force
and its share among meshes of the same gear pair scene (a planetary stage's load sharing), the
energy account, and two pictures (speeds, mesh forces)."""
from __future__ import annotations

import math
import pathlib

import numpy as np

from gearmesh.train_fmu import build_train_fmu, load_train

RPM = 2 * math.pi / 60


def simulate(fmu: pathlib.Path, train, run: dict) -> dict[str, np.ndarray]:
    """The run: name -> samples at the communication points (time first)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    speed = float(run.get("port_speed_rpm", 100.0)) * RPM
    ramp = float(run.get("ramp_s", 0.2))
    load = float(run.get("load_Nm", 0.0))
    load_body = run.get("load_body", train.bodies[-1]["name"])
    duration, h = float(run.get("duration_s", 1.0)), float(run.get("step_s", 1e-2))
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="GearTrain",
                  instanceName=train.name)
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    ports = [s["name"] for s in train.shafts if s["_other"] == -1]
    read = ([f"{b['name']}.speed" for b in train.bodies] + [f"{m['name']}.normal_force" for m in train.meshes] +
            [f"{m['name']}.te" for m in train.meshes] + ["energy.residual", "energy.work_in", "energy.kinetic",
                                                          "energy.elastic"])
    rows, angle, sense = [], 0.0, 1.0
    loaded = [b["name"] for b in train.bodies].index(load_body)  # its speed's column in read
    for k in range(int(round(duration / h))):
        t = k * h
        ramp_share = min(1.0, t / ramp) if ramp > 0 else 1.0
        omega = speed * ramp_share
        values = {}
        for p in ports:
            values[f"{p}.far_phi"], values[f"{p}.far_omega"] = angle, omega
        values[f"{load_body}.torque"] = -sense * load * ramp_share
        f.setReal([vr[n] for n in values], list(values.values()))
        f.doStep(t, h)
        angle += omega * h
        row = f.getReal([vr[n] for n in read])
        if abs(row[loaded]) > 1e-6:  # the load acts against the body's turning
            sense = math.copysign(1.0, row[loaded])
        rows.append([t + h, *row])
    f.terminate()
    f.freeInstance()
    x = np.array(rows)
    return {"time": x[:, 0], **{n: x[:, i + 1] for i, n in enumerate(read)}, "_port_speed": speed}


def section(train_scene: pathlib.Path, generic_fmu: pathlib.Path, out: pathlib.Path) -> str:
    """The report section of a train scene; the FMU, the samples and the pictures go to out/<name>/."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    train = load_train(train_scene)
    folder = out / train.name
    folder.mkdir(parents=True, exist_ok=True)
    fmu = build_train_fmu(train_scene, folder / f"{train.name}.fmu", generic_fmu)
    r = simulate(fmu, train, train.run)
    t = r["time"]
    last = t > t[-1] - 0.5 * (t[-1] - t[0])  # the second half: settled
    port = r["_port_speed"]
    lines = [f"## Train {train.name}", "",
             f"`{train_scene.name}`: {len(train.bodies)} bodies, {len(train.shafts)} shafts, {len(train.meshes)} "
             f"meshes; its FMU `{train.name}/{fmu.name}` run at {train.run.get('step_s', 1e-2):g} s steps, ports "
             f"ramped to {port / RPM:g} rpm, {train.run.get('load_Nm', 0.0):g} N m on "
             f"{train.run.get('load_body', train.bodies[-1]['name'])}; means over the second half of the samples at the "
             "communication points.", "",
             "| body | mean speed (rad/s) | ratio to the ports' speed |", "|---|---|---|"]
    for b in train.bodies:
        w = r[f"{b['name']}.speed"][last].mean()
        lines.append(f"| {b['name']} | {w:.4g} | {w / port:.5g} |")
    lines += ["", "| mesh | element scene | mean normal force (N) | share among its scene's meshes |", "|---|---|---|---|"]
    by_scene: dict[str, list[str]] = {}
    for m in train.meshes:
        by_scene.setdefault(str(m["_scene"]), []).append(m["name"])
    for m in train.meshes:
        mates = by_scene[str(m["_scene"])]
        force = r[f"{m['name']}.normal_force"][last].mean()
        total = sum(r[f"{n}.normal_force"][last].mean() for n in mates)
        share = f"{force / total:.4f}" if total > 0 else "–"
        lines.append(f"| {m['name']} | {m['_scene'].name} | {force:.4g} | {share} |")
    residual, work_in = r["energy.residual"][-1], r["energy.work_in"][-1]
    lines += ["", f"Energy: {work_in:.4g} J put in, residual {residual:+.3g} J "
              f"(positive: lost by the integrator; {residual / max(work_in, 1e-300):+.2g} of the work in).", ""]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for b in train.bodies:
        axes[0].plot(t, r[f"{b['name']}.speed"], label=b["name"])
    axes[0].set(xlabel="time (s)", ylabel="speed (rad/s)", title="body speeds")
    for m in train.meshes:
        axes[1].plot(t, r[f"{m['name']}.normal_force"], label=m["name"])
    axes[1].set(xlabel="time (s)", ylabel="normal force (N)", title="mesh forces at the communication points")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(folder / "train_run.png", dpi=100)
    plt.close(fig)
    lines += [f"![{train.name}]({train.name}/train_run.png)", ""]
    return "\n".join(lines)
