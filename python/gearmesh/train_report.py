"""The main job's section of a train scene: its FMU (gearmesh.train_fmu) run as a system
simulator would, at the scene's [run] step (default 1e-2 s): every port's far end ramped from
rest to port_speed_rpm and the load on load_body ramped to load_Nm against its turning, for
duration_s. Reported: each body's mean speed and its ratio to the port's, each mesh's mean force
and a planet mesh's share of its group's force (<mesh>.planet_share: a planetary stage's load sharing), the
energy account, and two pictures (speeds, mesh forces). Then the quasi-static train (the FMU's
model.quasi_static mode): the static equilibrium at every point of a sweep of the held body over
one revolution of the sweep body ([static] table), the load on load_body: the train's TE at the
output, each mesh's static TE and the load sharing among the meshes of the same pair scene
(planets), with the scene's pin errors and bearings."""
from __future__ import annotations

import math
import pathlib

import numpy as np

from gearmesh.train_fmu import build_train_fmu, load_train, planet_groups

RPM = 2 * math.pi / 60


def simulate(fmu: pathlib.Path, train, run: dict) -> dict[str, np.ndarray]:
    """The run: name -> samples at the communication points (time first)."""
    speed = float(run.get("port_speed_rpm", 100.0)) * RPM
    ramp = float(run.get("ramp_s", 0.2))
    load = float(run.get("load_Nm", 0.0))
    load_body = run.get("load_body", train.bodies[-1]["name"])
    duration, h = float(run.get("duration_s", 1.0)), float(run.get("step_s", 1e-2))
    f, vr = _open(fmu, train, train.name)
    f.enterInitializationMode()
    f.exitInitializationMode()
    ports = [s["name"] for s in train.shafts if s["_other"] == -1]
    read = ([f"{b['name']}.speed" for b in train.bodies] + [f"{m['name']}.normal_force" for m in train.meshes] +
            [f"{m['name']}.te" for m in train.meshes] + [f"{m['name']}.planet_share" for m in train.meshes] +
            ["energy.residual", "energy.work_in", "energy.kinetic",
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


def _open(fmu: pathlib.Path, train, name: str):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="GearTrain", instanceName=name)
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    return f, vr


def quasi_static(fmu: pathlib.Path, train, load_Nm: float | None = None, points: int | None = None,
                 parameters: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """The quasi-static sweep: name -> values per point ("held" the held body's angle; every body's
    .angle, every mesh's .te and .normal_force; the held body's holding torque). parameters: FMU
    parameters to set first (e.g. a pin error)."""
    names = [b["name"] for b in train.bodies]
    held = train.held_body()
    sweep = names.index(train.static.get("sweep_body", train.run.get("load_body", names[held])))
    load_body = train.run.get("load_body")
    load = float(train.run.get("load_Nm", 0.0) if load_Nm is None else load_Nm)
    points = int(train.static.get("points", 240) if points is None else points)
    ports = [s["name"] for s in train.shafts if s["_other"] == -1 and s["_body"] == held]
    f, vr = _open(fmu, train, train.name + "_static")
    f.setInteger([vr["model.quasi_static"]], [1])
    for name, value in (parameters or {}).items():
        f.setReal([vr[name]], [float(value)])
    read = ([f"{n}.angle" for n in names] + [f"{m['name']}.te" for m in train.meshes] +
            [f"{m['name']}.normal_force" for m in train.meshes] + [f"{m['name']}.planet_share" for m in train.meshes] +
            [f"{names[held]}.holding_torque"] +
            [f"{n}.{a}" for n in names for a in ("x", "y")])
    flanks = [f"{m['name']}.flank" for m in train.meshes]
    sense = 1.0

    def solve(k: int, angle: float) -> list[float]:
        values = {"static.held_angle": angle, **{f"{p}.far_phi": angle for p in ports}}
        if load_body:
            values[f"{load_body}.torque"] = -sense * load
        f.setReal([vr[n] for n in values], list(values.values()))
        if k == 0:
            f.enterInitializationMode()
            f.exitInitializationMode()
        f.doStep(k * 1.0, 1.0)
        return f.getReal([vr[n] for n in read]) + [float(i) for i in f.getInteger([vr[n] for n in flanks])]

    # the ratio of the sweep body to the held body, and the load body's sense, from a first step
    # unloaded (sense decided) then loaded
    first = solve(0, 0.0)
    probe = solve(1, 1e-3)
    ratio = (probe[sweep] - first[sweep]) / 1e-3 if sweep != held else 1.0
    if load_body:
        lb = names.index(load_body)
        sense = math.copysign(1.0, probe[lb] - first[lb])
    span = 2 * math.pi / abs(ratio)
    rows = []
    for k in range(points + 1):
        angle = math.copysign(span, ratio) * k / points
        rows.append([angle, *solve(k + 2, angle)])
    f.terminate()
    f.freeInstance()
    x = np.array(rows)
    out = {"held": x[:, 0], **{n: x[:, i + 1] for i, n in enumerate(read + flanks)}}
    out["_ratio"] = np.array(ratio)
    out["_sweep"] = np.array(sweep)
    return out


def sharing(train, r: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each planet mesh's share of its group's force per point (the FMU's <mesh>.planet_share;
    the groups: gearmesh.train_fmu.planet_groups)."""
    return {n: r[f"{n}.planet_share"] for mates in planet_groups(train).values() for n in mates}


def static_section(fmu: pathlib.Path, train, folder: pathlib.Path) -> list[str]:
    import matplotlib.pyplot as plt

    r = quasi_static(fmu, train)
    names = [b["name"] for b in train.bodies]
    held, sweep = train.held_body(), int(r["_sweep"])
    pins = [f"{b['name']} {b['_pin_error_tangential_um'] * 1e6:g}/{b['_pin_error_radial_um'] * 1e6:g} µm"
            for b in train.bodies if b["_pin_error_tangential_um"] or b["_pin_error_radial_um"]]
    bearings = [b["name"] + (" (floating)" if not b["_bearing_stiffness_N_per_m"] else
                             f" ({b['_bearing_stiffness_N_per_m']:.3g} N/m)")
                for b in train.bodies if b["_mass_kg"] > 0]
    load_body = train.run.get("load_body")
    lines = ["### Quasi-static", "",
             f"The static equilibrium at {len(r['held'])} angles of {names[held]} over one revolution of "
             f"{names[sweep]}, {train.run.get('load_Nm', 0.0):g} N m on {load_body or 'no body'}; pin errors "
             f"(tangential/radial): {', '.join(pins) or 'none'}; translating centres: {', '.join(bearings) or 'none'}.",
             ""]
    out_body = names.index(load_body) if load_body else sweep
    if out_body != held:
        ratio = np.polyfit(r["held"], r[f"{names[out_body]}.angle"], 1)[0]
        te_out = (r[f"{names[out_body]}.angle"] - ratio * r["held"]) * 1e6
        lines += [f"The train's TE at {names[out_body]} (its angle less {ratio:.6g} × {names[held]}'s): peak to "
                  f"peak {np.ptp(te_out):.4g} µrad.", ""]
    shares = sharing(train, r)
    lines += ["| mesh | flank | static TE mean (µm) | static TE p-p (µm) | mean force (N) | planet share: mean | min "
              "| max |", "|---|---|---|---|---|---|---|---|"]
    for m in train.meshes:
        te = r[f"{m['name']}.te"] * 1e6
        flank = {1: "A", 2: "B", 3: "A+B"}.get(int(np.median(r[f"{m['name']}.flank"])), "none")
        sh = shares.get(m["name"])
        share = f"{sh.mean():.4f} | {sh.min():.4f} | {sh.max():.4f}" if sh is not None else "– | – | –"
        lines.append(f"| {m['name']} | {flank} | {te.mean():.4g} | {np.ptp(te):.4g} | "
                     f"{r[m['name'] + '.normal_force'].mean():.4g} | {share} |")
    groups = planet_groups(train)
    if groups:
        factors = [f"{k}: {len(v) * max(shares[n].max() for n in v):.4f}" for k, v in groups.items()]
        lines += ["", "(A mesh on flank B has the backlash in its TE.) Load sharing factor K_γ = N × the largest "
                  "share over the sweep (ISO 6336-1 and AGMA 6123 name it so): " + "; ".join(factors) + ".", ""]
    angle = np.degrees(r[f"{names[sweep]}.angle"] - r[f"{names[sweep]}.angle"][0])
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for v in groups.values():
        for n in v:
            ax.plot(angle, shares[n], label=n)
    ax.set(xlabel=f"{names[sweep]} angle (deg)", ylabel="share of the group's force",
           title=f"{train.name}: quasi-static load sharing")
    ax.grid(True, alpha=0.3)
    if ax.lines:
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(folder / "train_static.png", dpi=100)
        lines += [f"![{train.name} quasi-static]({train.name}/train_static.png)", ""]
    plt.close(fig)
    return lines


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
    lines += ["", "| mesh | element scene | mean normal force (N) | mean planet share |", "|---|---|---|---|"]
    grouped = {n for mates in planet_groups(train).values() for n in mates}
    for m in train.meshes:
        force = r[f"{m['name']}.normal_force"][last].mean()
        share = f"{r[m['name'] + '.planet_share'][last].mean():.4f}" if m["name"] in grouped else "–"
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
    lines += static_section(fmu, train, folder)
    return "\n".join(lines)
