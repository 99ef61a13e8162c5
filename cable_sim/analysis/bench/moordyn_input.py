"""The scene's line as a MoorDyn v2 input file (the MoorDyn peer of issue #13).

:func:`line_from_scene` maps a scene's physical line onto MoorDyn's line-type properties, point
positions and options; :func:`input_text` writes the input file for a segment count and time
step. MoorDyn and cable_sim state the same physics with different conventions:

- mass per length, diameter (buoyancy and drag both on ``diameter``, as in cable_sim), water
  density and gravity are the same numbers;
- drag: cable_sim's Morison form ``F = -1/2 rho d l (Cdn |vn| vn + pi Cdt |vt| vt)`` is MoorDyn's
  (``Dp = 1/2 rho d l Cdn |vp| vp``, ``Dq = 1/2 rho pi d l Cdt |vq| vq``): Cd = ``drag_cn``,
  CdAx = ``drag_ct`` unchanged;
- added mass: cable_sim ``m_an = Can rho pi d^2 / 4`` per length, MoorDyn ``rho V Can``: Ca =
  ``added_mass_cn``, CaAx = ``added_mass_ct`` (0 when the scene's added mass is off);
- seabed: cable_sim states stiffness and damping per unit length, MoorDyn per area (Pa/m,
  Pa s/m): kBot = ``seabed_stiffness / d``, cBot = ``seabed_damping / d``; no friction in either;
- bending: EI = ``bending_stiffness`` (MoorDyn has no bending damping: cable_sim's
  ``bending_damping`` has no counterpart);
- axial: cable_sim's links are inextensible, MoorDyn's segments are springs: EA is large
  (default :data:`EA_DEFAULT`, a 76 mm studless chain's, stretch 0.05 % at 250 kN) with
  critical internal damping (BA = -1: damping ratio 1 per segment);
- geometry: cable_sim's plane (x, z) is MoorDyn's (x, 0, z); the whole line is shifted down by
  ``shift`` metres (default 20) so that the fairlead's heave never lifts a node above MoorDyn's
  free surface (z = 0; MoorDyn drops buoyancy and drag above it, cable_sim has no free surface
  on the line); the seabed is MoorDyn's water depth.

Part of the analysis layer: may import every layer; here scene only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cable_sim.scene.scenes import Scene

#: Axial stiffness of MoorDyn's segments [N]: R3 studless chain of 76 mm bar (EA ~ 0.854e11 d^2
#: per the usual chain tables with d in m), about 4.9e8 N; 250 kN stretches it by 0.05 %.
EA_DEFAULT = 5.0e8
#: Metres by which the line is lowered in MoorDyn (keeps it below MoorDyn's free surface).
SHIFT_DEFAULT = 20.0


@dataclass(frozen=True)
class MoorDynLine:
    """One anchored line in MoorDyn's terms (SI units; z up, MoorDyn's frame)."""

    length: float
    diameter: float
    mass_per_length: float
    ea: float
    ba: float
    ei: float
    cd: float
    ca: float
    cd_ax: float
    ca_ax: float
    anchor: tuple[float, float, float]
    fairlead: tuple[float, float, float]
    water_depth: float
    k_bot: float
    c_bot: float
    water_density: float
    gravity: float
    shift: float

    def to_moordyn_z(self, z: float) -> float:
        """A cable_sim z [m] in MoorDyn's frame."""
        return z - self.shift


class MoorDynMappingError(ValueError):
    """A scene the MoorDyn peer cannot express (names the parameter)."""


def line_from_scene(scene: Scene, fairlead_z: float, ea: float = EA_DEFAULT,
                    shift: float = SHIFT_DEFAULT) -> MoorDynLine:
    """The scene's line for MoorDyn, its fairlead at (0, ``fairlead_z``) of cable_sim's frame.

    Raises
    ------
    MoorDynMappingError
        When the scene is not a uniform, anchored line with Morison drag and a seabed.
    """
    p = scene.params
    if p.end_condition != "anchored":
        raise MoorDynMappingError(f"parameter 'end_condition' = {p.end_condition!r}; the MoorDyn "
                                  "peer needs 'anchored'")
    if p.drag_model != "morison":
        raise MoorDynMappingError(f"parameter 'drag_model' = {p.drag_model!r}; the MoorDyn peer "
                                  "needs 'morison'")
    if not p.seabed:
        raise MoorDynMappingError("parameter 'seabed' = False; the MoorDyn peer needs a seabed")
    ds = {float(x) for x in p.diameter}
    if len(ds) != 1:
        raise MoorDynMappingError(f"parameter 'diameter' varies along the line ({sorted(ds)}); the "
                                  "MoorDyn peer needs one line type")
    d = ds.pop()
    area = math.pi * d * d / 4.0
    if p.mass_per_length is not None:
        mpl = float(p.mass_per_length)
    else:
        rhos = {float(x) for x in p.line_density}
        if len(rhos) != 1:
            raise MoorDynMappingError("parameter 'line_density' varies along the line")
        mpl = rhos.pop() * area
    length = float(sum(scene.model().length))
    depth = shift - float(p.seabed_depth)
    return MoorDynLine(
        length=length, diameter=d, mass_per_length=mpl, ea=float(ea), ba=-1.0,
        ei=float(p.bending_stiffness) if p.stiffness_mode == "bending" else 0.0,
        cd=float(p.drag_cn), cd_ax=float(p.drag_ct),
        ca=float(p.added_mass_cn) if p.added_mass else 0.0,
        ca_ax=float(p.added_mass_ct) if p.added_mass else 0.0,
        anchor=(float(p.anchor_x), 0.0, float(p.anchor_z) - shift),
        fairlead=(0.0, 0.0, float(fairlead_z) - shift), water_depth=depth,
        k_bot=float(p.seabed_stiffness) / d, c_bot=float(p.seabed_damping) / d,
        water_density=float(p.water_density), gravity=float(p.gravity), shift=float(shift))


def input_text(line: MoorDynLine, nseg: int, dt: float, tscheme: str = "RK2", tmax_ic: float = 120.0,
               thresh_ic: float = 1e-3) -> str:
    """MoorDyn v2 input file: one line of ``nseg`` segments, a fixed anchor (point 1) and a
    coupled fairlead (point 2), internal step ``dt`` [s] with ``tscheme``, dynamic-relaxation
    initial conditions (``tmax_ic``, ``thresh_ic``), no output files."""
    a, f = line.anchor, line.fairlead
    return "\n".join([
        "--------------------- MoorDyn Input File ------------------------------------",
        "cable_sim benchmark peer: the scene's line (cable_sim/analysis/bench/moordyn_input.py)",
        "----------------------- LINE TYPES ------------------------------------------",
        "TypeName   Diam    Mass/m     EA         BA/-zeta    EI         Cd     Ca     CdAx    CaAx",
        "(name)     (m)     (kg/m)     (N)        (N-s/-)     (N-m^2)    (-)    (-)    (-)     (-)",
        f"line  {line.diameter!r}  {line.mass_per_length!r}  {line.ea!r}  {line.ba!r}  {line.ei!r}  "
        f"{line.cd!r}  {line.ca!r}  {line.cd_ax!r}  {line.ca_ax!r}",
        "---------------------- POINT PROPERTIES --------------------------------",
        "ID    Type      X       Y       Z       Mass   Volume  CdA    Ca",
        "(#)   (-)       (m)     (m)     (m)     (kg)   (m^3)   (m^2)  (-)",
        f"1     Fixed     {a[0]!r}  {a[1]!r}  {a[2]!r}  0  0  0  0",
        f"2     Coupled   {f[0]!r}  {f[1]!r}  {f[2]!r}  0  0  0  0",
        "---------------------- LINES ----------------------------------------",
        "ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  LineOutputs",
        "(#)   (name)     (#)      (#)       (m)       (-)     (-)",
        f"1     line       1        2        {line.length!r}  {int(nseg)}  -",
        "---------------------- OPTIONS -----------------------------------------",
        "0             writeLog      no log file",
        f"{dt!r}  dtM           internal time step (s)",
        f"{tscheme}  tScheme       time scheme",
        f"{line.k_bot!r}  kBot          seabed stiffness (Pa/m)",
        f"{line.c_bot!r}  cBot          seabed damping (Pa-s/m)",
        f"{line.water_density!r}  WtrDnsty      water density (kg/m^3)",
        f"{line.water_depth!r}  WtrDpth       water depth (m)",
        f"{line.gravity!r}  g             gravity (m/s^2)",
        "0.0           FrictionCoefficient  no seabed friction",
        "1.0           dtIC          IC convergence check interval (s)",
        f"{tmax_ic!r}  TmaxIC        max IC time (s)",
        f"{thresh_ic!r}  threshIC      IC convergence threshold (-)",
        "1             disableOutTime",
        "1             disableOutput",
        "------------------------- need this line --------------------------------------",
        "",
    ])


def parse_input(text: str) -> dict[str, dict]:
    """The line type, points, line and options of an input file written by :func:`input_text`
    (by MoorDyn's column headers), for checking what MoorDyn is given."""
    sections: dict[str, list[list[str]]] = {}
    current = None
    for raw in text.splitlines():
        if raw.startswith("---"):
            name = raw.strip("- ").upper()
            current = name if name in ("LINE TYPES", "POINT PROPERTIES", "LINES", "OPTIONS") else None
            if current:
                sections[current] = []
            continue
        if current and raw.strip():
            sections[current].append(raw.split())
    out: dict[str, dict] = {}
    for name in ("LINE TYPES", "POINT PROPERTIES", "LINES"):
        rows = sections[name]
        head = rows[0]
        out[name] = {r[0]: dict(zip(head, r, strict=False)) for r in rows[2:]}
    out["OPTIONS"] = {r[1]: r[0] for r in sections["OPTIONS"]}
    return out
