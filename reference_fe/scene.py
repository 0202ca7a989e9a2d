"""Scene files (TOML) read for the FE reference, independently of the product's tooling.

Only the keys a 2-D spur reference can honour are accepted; every other key of the scene
format is refused by name (nothing is silently unused). The key names and their units are the
scene format's (documented in the repository docs/tooling.md, "Scene format"); values are converted to SI
here and everything downstream is SI.
"""
from __future__ import annotations

import math
import pathlib
import tomllib
from dataclasses import dataclass, field


class SceneError(ValueError):
    """A scene key this reference cannot honour, or a value outside its range."""


@dataclass(frozen=True)
class Modification:
    """Profile modifications of one gear, SI (m), applied to both flanks alike."""
    crowning: float = 0.0            # C_alpha
    tip_relief: float = 0.0          # C_a
    tip_relief_length: float = 0.0   # L_a (roll length)
    tip_relief_parabolic: bool = False
    root_relief: float = 0.0         # C_f
    root_relief_length: float = 0.0  # L_f (roll length)
    root_relief_parabolic: bool = False
    slope: float = 0.0               # f_H_alpha (tip minus start of active profile)
    lead_crowning: float = 0.0       # C_beta (3-D only): C_beta (2 y / b)^2, y from mid-face

    def any(self) -> bool:
        """Any profile modification (the transverse outline differs from the involute)."""
        return any((self.crowning, self.tip_relief, self.root_relief, self.slope))


@dataclass(frozen=True)
class Body:
    """A gear body other than a solid disc (3-D only), SI: a web of `web_thickness` between
    the hub (radius `hub`) and the rim (inner radius `rim_inner`), its mid-plane `web_offset`
    from mid-face; the hub and the rim span the face width; `holes` lightening holes of radius
    `hole_radius` with centres on radius `hole_circle`, hole 0 on tooth 0's centre line, through
    the web (or, without a web, through the disc). The scene format's keys (repository
    docs/tooling.md, "Scene format": [gear<i>.body])."""
    rim_inner: float = 0.0
    hub: float = 0.0
    web_thickness: float = 0.0
    web_offset: float = 0.0
    holes: int = 0
    hole_radius: float = 0.0
    hole_circle: float = 0.0
    ring_outer: float = 0.0   # an internal ring's clamped outer radius (2-D: the ring's body)

    def web(self) -> bool:
        return self.rim_inner > 0

    def solid(self) -> bool:
        return not self.web() and not self.holes


@dataclass(frozen=True)
class GearSpec:
    teeth: int
    shift: float                 # x
    face_width: float            # b, m
    tip_diameter: float          # 0 = from the basic rack
    thickness_allowance: float   # A_sn, m (<= 0)
    youngs_modulus: float        # Pa
    poisson_ratio: float
    bore_diameter: float         # 0 = default 0.4 d_f
    mod: Modification = field(default_factory=Modification)
    body: Body = field(default_factory=Body)


@dataclass(frozen=True)
class PairSpec:
    name: str
    path: pathlib.Path
    center_distance: float   # a, m
    module: float            # m_n, m
    pressure_angle: float    # alpha_n, rad
    rack_addendum: float     # h_aP*, modules (the gear's addendum: the cutter's dedendum)
    rack_dedendum: float     # h_fP*, modules (the gear's dedendum: the cutter's addendum)
    rack_tip_radius: float   # rho_fP*, modules (the cutter's tip radius)
    gear1: GearSpec
    gear2: GearSpec
    friction: float          # scene's mu (used only when friction is switched on)
    torques: tuple[float, ...]  # N m, from [run] torques_Nm
    helix_angle: float = 0.0    # beta, rad (3-D only; 2-D: spur)
    slices: int = 0             # the product's slices across the face ([model] slices; 0: unset)
    internal: bool = False      # gear 2 an internal ring (2-D only: spur, unmodified)

    def gear(self, i: int) -> GearSpec:
        return self.gear1 if i == 1 else self.gear2


# scene key -> (SI factor, lo, hi) in the scene's unit; the units are in the key names
_PAIR = {
    "center_distance_mm": (1e-3, 1.0, 20000.0),
    "normal_module_mm": (1e-3, 0.1, 100.0),
    "pressure_angle_deg": (math.pi / 180, 10.0, 35.0),
    "helix_angle_deg": (math.pi / 180, 0.0, 0.0),       # 2-D: spur only
    "internal": (None, None, None),                     # true: gear 2 an internal ring (2-D)
    "rack_addendum": (1.0, 0.5, 2.0),
    "rack_dedendum": (1.0, 0.5, 3.0),
    "rack_tip_radius": (1.0, 0.0, 1.0),
}
_GEAR = {
    "teeth": (1, 5, 2000),
    "profile_shift": (1.0, -1.5, 3.0),
    "face_width_mm": (1e-3, 0.01, 2000.0),
    "tip_diameter_mm": (1e-3, 0.0, 40000.0),
    "thickness_allowance_um": (1e-6, -50000.0, 0.0),
    "youngs_modulus_GPa": (1e9, 0.1, 10000.0),
    "poisson_ratio": (1.0, 0.0, 0.499),
    "profile_crowning_um": (1e-6, 0.0, 1000.0),
    "tip_relief_um": (1e-6, 0.0, 1000.0),
    "tip_relief_length_mm": (1e-3, 0.0, 1000.0),
    "tip_relief_parabolic": (None, None, None),
    "root_relief_um": (1e-6, 0.0, 1000.0),
    "root_relief_length_mm": (1e-3, 0.0, 1000.0),
    "root_relief_parabolic": (None, None, None),
    "profile_slope_um": (1e-6, -1000.0, 1000.0),
}
# keys of the scene format that a 2-D spur model cannot represent: refused by name
_GEAR_REFUSED = {"axial_offset_mm", "lead_crowning_um", "helix_slope_um", "end_relief_um",
                 "end_relief_length_mm", "deviations_file"}
# what the 3-D model (load(..., dims=3)) honours in addition: helix angle, lead crowning
_PAIR_3D = {"helix_angle_deg": (math.pi / 180, 0.0, 40.0)}
_GEAR_3D = {"lead_crowning_um": (1e-6, 0.0, 1000.0)}
# [gear<i>.body] keys besides bore_diameter_mm that the 3-D model honours (whole gears only)
_BODY_3D = {"rim_inner_diameter_mm": (1e-3, 0.01, 40000.0), "hub_diameter_mm": (1e-3, 0.01, 40000.0),
            "web_thickness_mm": (1e-3, 0.01, 2000.0), "web_offset_mm": (1e-3, -1000.0, 1000.0),
            "holes": (1, 1, 500), "hole_diameter_mm": (1e-3, 0.01, 40000.0),
            "hole_circle_diameter_mm": (1e-3, 0.01, 40000.0)}


def _num(where: str, value, spec) -> float:
    factor, lo, hi = spec
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{where} = {value!r}: not a number")
    if not lo <= value <= hi:
        raise SceneError(f"{where} = {value!r}: outside the range this reference handles "
                         f"[{lo:g}, {hi:g}]")
    return float(value) * factor


def _body(i: int, body: dict) -> Body:
    """The [gear<i>.body] web, hub and holes (SI); refused when incomplete or inconsistent."""
    v = {k: _num(f"gear{i}.body.{k}", body[k], _BODY_3D[k]) for k in _BODY_3D if k in body}
    web_keys = ("rim_inner_diameter_mm", "hub_diameter_mm", "web_thickness_mm")
    if any(k in v for k in web_keys) and not all(k in v for k in web_keys):
        raise SceneError(f"gear{i}.body: a web needs {', '.join(web_keys)} together")
    if "web_offset_mm" in v and "web_thickness_mm" not in v:
        raise SceneError(f"gear{i}.body.web_offset_mm needs a web")
    hole_keys = ("holes", "hole_diameter_mm", "hole_circle_diameter_mm")
    if any(k in v for k in hole_keys) and not all(k in v for k in hole_keys):
        raise SceneError(f"gear{i}.body: holes need {', '.join(hole_keys)} together")
    return Body(rim_inner=v.get("rim_inner_diameter_mm", 0.0) / 2,
                hub=v.get("hub_diameter_mm", 0.0) / 2,
                web_thickness=v.get("web_thickness_mm", 0.0),
                web_offset=v.get("web_offset_mm", 0.0), holes=int(v.get("holes", 0)),
                hole_radius=v.get("hole_diameter_mm", 0.0) / 2,
                hole_circle=v.get("hole_circle_diameter_mm", 0.0) / 2)


def load(path: str | pathlib.Path, dims: int = 2) -> PairSpec:
    """Read a scene file into a PairSpec (SI). dims=3 admits what the 3-D model honours in
    addition (helix angle, lead crowning); everything else is refused as in 2-D."""
    path = pathlib.Path(path)
    pair_keys = {**_PAIR, **(_PAIR_3D if dims == 3 else {})}
    gear_keys = {**_GEAR, **(_GEAR_3D if dims == 3 else {})}
    refused = _GEAR_REFUSED - (set(_GEAR_3D) if dims == 3 else set())
    with open(path, "rb") as f:
        raw = tomllib.load(f)
    name = raw.get("scene", {}).get("name", path.stem)
    pair = raw.get("pair", {})
    for key in pair:
        if key not in pair_keys:
            raise SceneError(f"pair.{key}: not a key of the scene format this reference knows")
    internal = pair.get("internal", False)
    if not isinstance(internal, bool):
        raise SceneError(f"pair.internal = {internal!r}: not a Boolean")
    if internal and dims == 3:
        raise SceneError("pair.internal = true: the 3-D reference models external pairs only "
                         "(the 2-D one takes an internal spur ring)")
    p = {k: _num(f"pair.{k}", v, pair_keys[k]) for k, v in pair.items() if k != "internal"}
    for k in ("center_distance_mm", "normal_module_mm"):
        if k not in p:
            raise SceneError(f"pair.{k}: missing")
    gears = []
    for i in (1, 2):
        sec = raw.get(f"gear{i}", {})
        g = {}
        body = {}
        for key, value in sec.items():
            if key == "body":
                body = value
                continue
            if key in refused:
                raise SceneError(f"gear{i}.{key}: not representable in the {dims}-D reference")
            if key not in gear_keys:
                raise SceneError(f"gear{i}.{key}: not a key of the scene format this reference knows")
            if gear_keys[key][0] is None:
                if not isinstance(value, bool):
                    raise SceneError(f"gear{i}.{key} = {value!r}: not a Boolean")
                g[key] = value
            else:
                g[key] = _num(f"gear{i}.{key}", value, gear_keys[key])
        ring = internal and i == 2
        body_keys = ({"ring_outer_diameter_mm"} if ring
                     else {"bore_diameter_mm", *(_BODY_3D if dims == 3 else ())})
        for key in body:
            if key not in body_keys:
                raise SceneError(f"gear{i}.body.{key}: the {dims}-D reference models "
                                 + ("a solid disc with a bore only (allowed: bore_diameter_mm)"
                                    if dims == 2 else "a bore, a web, a hub and lightening "
                                    "holes only (allowed: " + ", ".join(sorted(body_keys)) + ")"))
        bspec = _body(i, body) if dims == 3 else Body()
        if ring:
            if "ring_outer_diameter_mm" not in body:
                raise SceneError("gear2.body.ring_outer_diameter_mm: missing (the internal ring's "
                                 "clamped outer diameter)")
            bspec = Body(ring_outer=_num("gear2.body.ring_outer_diameter_mm",
                                         body["ring_outer_diameter_mm"], (1e-3, 0.01, 40000.0)) / 2)
        for key in ("teeth", "face_width_mm"):
            if key not in g:
                raise SceneError(f"gear{i}.{key}: missing")
        mod = Modification(
            crowning=g.get("profile_crowning_um", 0.0),
            tip_relief=g.get("tip_relief_um", 0.0),
            tip_relief_length=g.get("tip_relief_length_mm", 0.0),
            tip_relief_parabolic=g.get("tip_relief_parabolic", False),
            root_relief=g.get("root_relief_um", 0.0),
            root_relief_length=g.get("root_relief_length_mm", 0.0),
            root_relief_parabolic=g.get("root_relief_parabolic", False),
            slope=g.get("profile_slope_um", 0.0),
            lead_crowning=g.get("lead_crowning_um", 0.0))
        if mod.tip_relief and not mod.tip_relief_length:
            raise SceneError(f"gear{i}.tip_relief_um needs tip_relief_length_mm > 0")
        if mod.root_relief and not mod.root_relief_length:
            raise SceneError(f"gear{i}.root_relief_um needs root_relief_length_mm > 0")
        bore = 0.0
        if "bore_diameter_mm" in body:
            bore = _num(f"gear{i}.body.bore_diameter_mm", body["bore_diameter_mm"],
                        (1e-3, 0.01, 40000.0))
        gears.append(GearSpec(
            teeth=int(g["teeth"]), shift=g.get("profile_shift", 0.0),
            face_width=g["face_width_mm"], tip_diameter=g.get("tip_diameter_mm", 0.0),
            thickness_allowance=g.get("thickness_allowance_um", 0.0),
            youngs_modulus=g.get("youngs_modulus_GPa", 210e9),
            poisson_ratio=g.get("poisson_ratio", 0.3), bore_diameter=bore, mod=mod,
            body=bspec))
    if internal and (any(g.mod.any() or g.mod.lead_crowning for g in gears)
                     or any(g.thickness_allowance for g in gears)):
        raise SceneError("pair.internal = true with micro-geometry or a thickness allowance: not "
                         "implemented in the reference (unmodified internal pairs only)")
    run = raw.get("run", {})
    torques = tuple(float(t) for t in run.get("torques_Nm", [50.0, 150.0, 250.0, 350.0]))
    mu = float(raw.get("model", {}).get("friction_coefficient", 0.0))
    return PairSpec(
        name=name, path=path, center_distance=p["center_distance_mm"],
        module=p["normal_module_mm"], pressure_angle=p.get("pressure_angle_deg", math.radians(20)),
        rack_addendum=p.get("rack_addendum", 1.0), rack_dedendum=p.get("rack_dedendum", 1.25),
        rack_tip_radius=p.get("rack_tip_radius", 0.38), gear1=gears[0], gear2=gears[1],
        friction=mu, torques=torques, helix_angle=p.get("helix_angle_deg", 0.0),
        slices=int(raw.get("model", {}).get("slices", 0)), internal=internal)
