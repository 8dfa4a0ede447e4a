"""Analytic bounds of push recovery without stepping, for the sagittal HOAP-2 model (docs/capability.md).

The robot as the bounds see it: the two-link body (links 1 and 2, mass m_b) erect, its CoM over the
ankle axis (x = 0); the feet (m_f, CoM at x_f) flat on the ground, toe at x_toe, heel at x_heel;
a horizontal push F (+ forward, i.e. on the back; - on the chest) at the height h above the sole.
x is measured from the ankle axis (forward +), heights above the sole. Pure numpy, no FMU calls.

* static_tipping_force: the constant push that tips the erect robot onto the toe (heel).
* sustained_push_limit: the largest constant push any flat-footed strategy can hold, the body CoM
  leaned to the opposite edge.
* lip_force_limit / lip_impulse_limit: the linear inverted pendulum bound of the ankle strategy
  (the body rigid, no angular momentum about its CoM, the ZMP at the edge from the push onset).

In every horizontal direction (docs/capability.md §7), for the robot on both feet: `Stance` (the
sagittal Robot plus the frontal numbers: stance width, leg length, roll inertias, the erect CoM's
offsets), its support polygon (the rectangle that is the convex hull of the two soles) and the same
three bounds as functions of the push's direction angle (0 = forward, 90 deg = toward +y, the left):
static_tipping_force_3d, sustained_push_limit_3d, lip_force_limit_3d, lip_impulse_limit_3d. The
lateral pendulum is the double-support parallelogram (legs rolling about their ankles, the upper
body translating): Stance.omega_y. stance_from_params reads a Stance from plant parameters completed
by the generated header hoap2/nominal.h (header_numbers).

    python -m anklehip.analysis.bounds       # the nominal numbers (docs/capability.md §5 and §7)
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Robot:
    """The numbers the bounds need (SI). Body links: mass, CoM height above the sole, pitch inertia
    about the own CoM. The erect body's CoM is at x = 0."""
    g: float
    m1: float
    z1: float
    I1: float
    m2: float
    z2: float
    I2: float
    ankle_height: float
    m_f: float          # feet
    x_f: float
    x_toe: float
    x_heel: float
    h: float            # push height above the sole

    @property
    def m_b(self) -> float:
        return self.m1 + self.m2

    @property
    def m_tot(self) -> float:
        return self.m_b + self.m_f

    @property
    def z_b(self) -> float:
        """Body CoM height above the sole."""
        return (self.m1 * self.z1 + self.m2 * self.z2) / self.m_b

    @property
    def I_b(self) -> float:
        """Body pitch inertia about its own CoM (erect)."""
        zb = self.z_b
        return self.I1 + self.I2 + self.m1 * (self.z1 - zb) ** 2 + self.m2 * (self.z2 - zb) ** 2

    @property
    def I_ankle(self) -> float:
        """Body pitch inertia about the ankle axis (erect)."""
        return self.I_b + self.m_b * (self.z_b - self.ankle_height) ** 2

    @property
    def I_sole(self) -> float:
        """Body pitch inertia about the sole point under the ankle: sum of I_i + m_i z_i^2."""
        return self.I_b + self.m_b * self.z_b ** 2

    @property
    def omega(self) -> float:
        """LIP rate [1/s] of the rigid body pivoting about the ankle axis (the model's kinematics),
        rotational inertia included: omega^2 = m_b g z_a / (m_b z_b z_a + I_b), z_a = z_b - ankle_height.
        The bounds use this one."""
        za = self.z_b - self.ankle_height
        return math.sqrt(self.m_b * self.g * za / (self.m_b * self.z_b * za + self.I_b))

    @property
    def omega_sole(self) -> float:
        """The same for a rigid body pivoting on the sole point: omega^2 = m_b g z_b / I_sole."""
        return math.sqrt(self.m_b * self.g * self.z_b / self.I_sole)

    @property
    def omega_point(self) -> float:
        """Point-mass LIP (no rotational inertia): omega^2 = g / z_b."""
        return math.sqrt(self.g / self.z_b)


def robot_from_plant_params(params: dict) -> Robot:
    """A Robot from the plant FMU's parameters (start values merged with any overrides; names g,
    m1, l1, lg1, I1, m2, lg2, I2, feet_mass, feet_com_x, toe_x, heel_x, ankle_height, h_push)."""
    p = {k: float(v) for k, v in params.items() if isinstance(v, (int, float))}
    a = p["ankle_height"]
    return Robot(g=p["g"], m1=p["m1"], z1=a + p["lg1"], I1=p["I1"], m2=p["m2"], z2=a + p["l1"] + p["lg2"],
                 I2=p["I2"], ankle_height=a, m_f=p["feet_mass"], x_f=p["feet_com_x"], x_toe=p["toe_x"],
                 x_heel=p["heel_x"], h=p["h_push"])


def _edge_moment(r: Robot, direction: float) -> float:
    """m_b * Delta_eff [kg m]: the first moment of the erect robot's masses about the edge the push
    tips it onto (the toe for direction +1, the heel for -1), positive when the robot stands."""
    if direction >= 0:
        return r.m_b * r.x_toe + r.m_f * (r.x_toe - r.x_f)
    return r.m_b * (-r.x_heel) + r.m_f * (r.x_f - r.x_heel)


def static_tipping_force(r: Robot, direction: float = +1) -> float:
    """Constant push [N, magnitude] that tips the erect robot onto the toe (direction +1, push on
    the back) or the heel (-1, on the chest): moment balance about that edge,
    F h = g [m_b (x_toe - 0) + m_f (x_toe - x_f)].
    Assumes: erect posture held rigidly (no lean), feet flat, push horizontal at h."""
    return r.g * _edge_moment(r, direction) / r.h


def sustained_push_limit(r: Robot, direction: float = +1) -> float:
    """Largest constant push [N, magnitude] any flat-footed strategy can hold without stepping:
    the ZMP at the toe and the body CoM leaned to the heel (mirrored for a push on the chest),
    F h = g [m_b (x_toe - x_heel) + m_f (x_toe - x_f)].
    Assumes: the body CoM stays over the sole (the robot still stands if the push stops), h
    unchanged by the lean (small angles), feet flat, push horizontal."""
    if direction >= 0:
        m = r.m_b * (r.x_toe - r.x_heel) + r.m_f * (r.x_toe - r.x_f)
    else:
        m = r.m_b * (r.x_toe - r.x_heel) + r.m_f * (r.x_f - r.x_heel)
    return r.g * m / r.h


def laplace_pwl(times, values, omega: float):
    """Integral of f(t) e^(-omega t) dt from times[..., 0] to infinity, exact for the piecewise-linear
    f through the break points (times, values) along the last axis (a repeated time is a jump),
    constant at the last value after the last break point (as anklehip.files.scenario.PushProfile)."""
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    t0, t1, v0, v1 = t[..., :-1], t[..., 1:], v[..., :-1], v[..., 1:]
    dt = t1 - t0
    e0 = np.exp(-omega * t0)
    d = -e0 * np.expm1(-omega * dt)                 # e^(-w t0) - e^(-w t1), accurate for short segments
    with np.errstate(invalid="ignore", divide="ignore"):
        # the linear part: (v1 - v0) [d / (w^2 dt) - e^(-w t1) / w]
        lin = np.where(dt > 0, d / (omega ** 2 * np.where(dt > 0, dt, 1.0)) - (e0 - d) / omega, 0.0)
    seg = v0 * d / omega + (v1 - v0) * lin
    tail = v[..., -1] * np.exp(-omega * t[..., -1]) / omega
    return seg.sum(axis=-1) + tail


def trapezoid_integral(omega: float, duration, rise: float = 0.0):
    """Integral of s(t) e^(-omega t) dt for the sweeps' trapezoid push normalised to peak 1: from
    t = 0, up in `rise`, held, down in `rise`, zero after `duration` (rise and fall included), the
    break points of PushProfile.from_segments([PushSegment("pulse", t=0, force=1, duration, rise)]).
    Vectorised over duration; duration = inf is a push that never ends; rise is clipped to duration/2."""
    D = np.asarray(duration, float)
    r = np.minimum(rise, D / 2)
    inf = np.isinf(D)
    Df = np.where(inf, 2 * r, D)
    times = np.stack([np.zeros_like(D), r, Df - r, Df], axis=-1)
    values = np.where(inf[..., None], [0.0, 1.0, 1.0, 1.0], [0.0, 1.0, 1.0, 0.0])
    return laplace_pwl(times, values, omega)


def lip_force_limit(r: Robot, duration, rise: float = 0.0, direction: float = +1, omega: float | None = None):
    """Largest peak force [N, magnitude] of a trapezoid push (duration, rise; see trapezoid_integral)
    after which the ankle strategy can still be capturable:
    F_max = m_b g Delta_eff / (h omega integral s(t) e^(-omega t) dt), m_b g Delta_eff = F_static h.
    Assumes: linear inverted pendulum of the rigid erect body pivoting about the ankle (rotational
    inertia included, omega = r.omega unless given), no angular momentum about the CoM from the hip,
    the ZMP at the toe (heel for direction -1) from the push onset, feet flat, the robot erect and at
    rest before the push. A necessary condition: above it no flat-footed ankle strategy recovers;
    below it recovery is possible in the model, not guaranteed. Vectorised over duration; a
    constant push (duration inf, rise 0) gives static_tipping_force."""
    w = r.omega if omega is None else omega
    return r.g * _edge_moment(r, direction) / (r.h * w * trapezoid_integral(w, duration, rise))


def lip_impulse_limit(r: Robot, direction: float = +1, omega: float | None = None) -> float:
    """Largest impulse [N s, magnitude] of a very short push the ankle strategy can absorb:
    J_max = m_b g Delta_eff / (h omega), the limit of F_max * duration for duration -> 0.
    Assumes what lip_force_limit assumes."""
    w = r.omega if omega is None else omega
    return r.g * _edge_moment(r, direction) / (r.h * w)



# ---------------------------------------------------------------------------------------------
# the flat-footed optimum (docs/capability.md section 8): cached trajectory-optimization results

OPTIMUM_FILE = "flat_footed_optimum.json"       # in anklehip/analysis/data/, made by scripts/flat_footed_optimum.py
# the numbers the optimum depends on (bounds_parameters' names); mu: Hoap2Plant3D's friction coefficient
OPTIMUM_PARAMETERS = ("g", "m1", "l1", "lg1", "I1", "m2", "lg2", "I2", "feet_mass", "feet_com_x", "toe_x", "heel_x",
                      "ankle_height", "h_push", "tau_max_ankle", "tau_max_hip", "vel_max_ankle", "vel_max_hip",
                      "ankle_min", "ankle_max", "hip_min", "hip_max")


def optimum_parameters(params: dict) -> dict[str, float]:
    """The numbers of bounds_parameters (plant parameters completed by the header) the flat-footed
    optimum depends on, by name; KeyError naming the missing ones."""
    missing = [k for k in OPTIMUM_PARAMETERS if k not in params]
    if missing:
        raise KeyError(f"the flat-footed optimum needs {', '.join(missing)}")
    return {k: float(params[k]) for k in OPTIMUM_PARAMETERS}


def _load_cache(path, name: str, what: str, script: str) -> dict:
    """A cached optimum: the JSON at path, or the package's data file `name`; InputError naming the
    file and the script that makes it when there is none."""
    import json
    from pathlib import Path
    p = Path(path) if path is not None else Path(__file__).parent / "data" / name
    try:
        return json.loads(p.read_text())
    except FileNotFoundError:
        from ..errors import InputError
        raise InputError(f"{p}: no cached {what} (make it: python scripts/{script})") from None


def load_optimum(path=None) -> dict:
    """The cached flat-footed optimum (JSON written by scripts/flat_footed_optimum.py): its parameters,
    settings and points. path: the package's data file unless given."""
    return _load_cache(path, OPTIMUM_FILE, "flat-footed optimum", "flat_footed_optimum.py")


def optimum_matches(data: dict, params: dict, rel: float = 1e-9) -> list[str]:
    """The names of the numbers in which params (bounds_parameters') differ from those the cached
    optimum was computed for (relative rel); push heights other than the cached ones are allowed
    where the cache has them, so h_push is not compared. [] when the cache applies."""
    try:
        mine = optimum_parameters(params)
    except KeyError as e:
        return [str(e)]
    theirs = data["parameters"]
    return [k for k in OPTIMUM_PARAMETERS if k != "h_push"
            and not math.isclose(mine[k], theirs.get(k, math.nan), rel_tol=rel, abs_tol=1e-15)]


def flat_footed_optimum(duration, rise: float = 0.05, direction: float = +1, height: float | None = None,
                        params: dict | None = None, data: dict | None = None):
    """Largest peak force [N, magnitude] of a trapezoid push (duration, rise; the sweeps' pulse) on the
    back (direction +1) or the chest (-1) at `height` (the cached nominal h_push unless given) that
    any flat-footed controller survives: the cached trajectory optimum of the sagittal model with the
    robot's limits (anklehip.analysis.flat_footed, docs/capability.md section 8).

    Between cached durations F is interpolated linearly in log(duration); between cached heights (only
    where the cache holds a height grid for that duration) F h linearly in h. Exact cached rises only.
    InputError (a ValueError) outside the cache, naming the cached range; and when params (the
    plant's bounds_parameters) are given and differ from the cached robot (the cache is stale for
    that robot). Vectorised over duration."""
    from ..errors import InputError
    data = load_optimum() if data is None else data
    if params is not None:
        bad = optimum_matches(data, params)
        if bad:
            raise InputError(f"the cached flat-footed optimum ({OPTIMUM_FILE}) was computed for another robot: "
                             f"{', '.join(bad)} differ; regenerate it with scripts/flat_footed_optimum.py")
    d = 1 if direction >= 0 else -1
    h0 = data["parameters"]["h_push"]
    h = h0 if height is None else float(height)
    pts = [p for p in data["points"] if p["direction"] == d and p["ok"]]
    rises = sorted({p["rise"] for p in pts})
    same_rise = [p for p in pts if math.isclose(p["rise"], rise, rel_tol=1e-9, abs_tol=1e-12)]
    if not same_rise:
        raise InputError(f"flat-footed optimum: rise {rise:g} s is not cached (cached rises: "
                         f"{', '.join(f'{x:g}' for x in rises)} s)")
    D = np.asarray(duration, float)

    def along_duration(rows, x):
        ds = np.array([p["duration"] for p in rows])
        fs = np.array([p["f_peak"] for p in rows])
        o = np.argsort(ds)
        ds, fs = ds[o], fs[o]
        if np.any(x < ds[0] * (1 - 1e-9)) or np.any(x > ds[-1] * (1 + 1e-9)):
            raise InputError(f"flat-footed optimum: duration {np.min(x):g}..{np.max(x):g} s outside the cached "
                             f"{ds[0]:g}..{ds[-1]:g} s (rise {rise:g} s, direction {d:+d}, h {h:g} m)")
        return np.interp(np.log(np.clip(x, ds[0], ds[-1])), np.log(ds), fs)

    at_h = [p for p in same_rise if math.isclose(p["height"], h, rel_tol=1e-9)]
    if len({p["duration"] for p in at_h}) >= 2:
        out = along_duration(at_h, D)
        return float(out) if np.ndim(out) == 0 else out
    # a height grid at single durations
    rows = [p for p in same_rise if np.all(np.isclose(D, p["duration"], rtol=1e-9))]
    hs = np.array(sorted({p["height"] for p in rows}))
    if len(hs) < 2 or not hs[0] * (1 - 1e-9) <= h <= hs[-1] * (1 + 1e-9):
        have = sorted({(p["duration"], p["height"]) for p in same_rise if not math.isclose(p["height"], h0)})
        raise InputError(f"flat-footed optimum: height {h:g} m (duration {np.max(D):g} s, rise {rise:g} s) is not "
                         f"cached; heights are cached at h = {h0:g} m for every duration and at "
                         f"{sorted({x for _, x in have}) or 'no other height'} for durations "
                         f"{sorted({x for x, _ in have}) or '-'} s")
    fh = np.array([next(p["f_peak"] for p in rows if p["height"] == x) * x for x in hs])
    out = np.full(D.shape, float(np.interp(h, hs, fh)) / h)
    return float(out) if np.ndim(out) == 0 else out



# the one-step optimum (docs/capability.md section 9.3): cached trajectory-optimization results of the
# whole robot's sagittal model (anklehip.analysis.one_step) stepping once

ONE_STEP_FILE = "one_step_optimum.json"       # in anklehip/analysis/data/, made by scripts/one_step_optimum.py
ONE_STEP_FORWARD = 0.05      # a converged point is a step forward when it lands more than this ahead [m]
ONE_STEP_MESH_TOL = 0.005    # a point counts when its two meshes (50 and 25 ms) agree within this (relative)


def is_step_forward(ok: bool, landing: float) -> bool:
    """A one-step solve that counts: IPOPT converged (success or its acceptable level) to a landing
    more than ONE_STEP_FORWARD ahead, not to the step in place (a poorer local optimum)."""
    return bool(ok) and landing > ONE_STEP_FORWARD


def one_step_series(point: dict) -> tuple[float, float]:
    """A cached one-step point's series: (the lift time after the onset [s], the swing sole's clearance
    over mid-swing [m]; 0 in caches made before the clearance)."""
    return point["t_lift"], point.get("clearance", 0.0)


def load_one_step_optimum(path=None) -> dict:
    """The cached one-step optimum (JSON written by scripts/one_step_optimum.py): its settings (the push
    height among them), the hashes of its sources, and its points (per landing time). path: the
    package's data file unless given."""
    return _load_cache(path, ONE_STEP_FILE, "one-step optimum", "one_step_optimum.py")


def one_step_points(data: dict | None = None, duration: float = 1.0, rise: float = 0.05, t_lift: float = 0.0,
                    clearance: float = 0.0) -> list[dict]:
    """The cached one-step points of a back push (duration, rise) and a series (the step lifting t_lift
    after the onset, its sole at least `clearance` [m] above the ground over mid-swing) that IPOPT solved
    on both meshes (success or its acceptable level) to a step forward (landing more than
    ONE_STEP_FORWARD ahead: not the step in place, a poorer local optimum), the two meshes agreeing
    within ONE_STEP_MESH_TOL (not a coarse solve that found a poorer local optimum), by landing time."""
    data = load_one_step_optimum() if data is None else data
    return sorted((p for p in data["points"] if is_step_forward(p["ok"], p["landing"])
                   and abs(p["rel_change_mesh"]) < ONE_STEP_MESH_TOL
                   and math.isclose(p["duration"], duration, rel_tol=1e-9)
                   and math.isclose(p["rise"], rise, rel_tol=1e-9, abs_tol=1e-12)
                   and all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(one_step_series(p), (t_lift, clearance)))),
                  key=lambda p: p["t_land"])


def one_step_optimum(duration: float = 1.0, rise: float = 0.05, data: dict | None = None, t_lift: float = 0.0,
                     clearance: float = 0.0) -> tuple[float, float]:
    """The largest peak force [N] of a back push (duration, rise) at the cached push height that the
    whole robot survives with one step (lifting t_lift after the onset, its sole `clearance` clear over
    mid-swing; by default at the onset, free to skim the ground), and the landing time [s after the
    onset] that gives it: the best of the cached landing times (one_step_points; a local optimum of
    each, docs/capability.md section 9.3, so what one step can do at least, not a bound above).
    InputError when the push or the series is not cached."""
    pts = one_step_points(data, duration, rise, t_lift, clearance)
    if not pts:
        from ..errors import InputError
        raise InputError(f"one-step optimum: no converged point cached for a {duration:g} s back push with "
                         f"{1000 * rise:g} ms ramps, the step lifting {1000 * t_lift:g} ms after the onset with "
                         f"{1000 * clearance:g} mm clearance ({ONE_STEP_FILE}; make it with scripts/one_step_optimum.py)")
    best = max(pts, key=lambda p: p["f_peak"])
    return float(best["f_peak"]), float(best["t_land"])


_IPOPT_WORDS = {"Solve_Succeeded": "success", "Solved_To_Acceptable_Level": "acceptable level"}


def one_step_table(data: dict | None = None) -> str:
    """The cached one-step optimum (docs/capability.md section 9.3) as markdown tables, one per series
    (the lift time and the swing sole's clearance): per landing time the force on both meshes and the
    change, IPOPT's status on the finer, where the step landed, the stance ankle's largest angle and
    the landed foot's drift on each mesh; a point that did not converge to a step forward says so."""
    data = load_one_step_optimum() if data is None else data
    out = []
    for t_lift, clearance in sorted({one_step_series(p) for p in data["points"]}):
        pts = sorted((p for p in data["points"] if one_step_series(p) == (t_lift, clearance)),
                     key=lambda p: p["t_land"])
        out.append(f"The step lifting {1000 * t_lift:g} ms after the onset, its sole "
                   + (f"at least {1000 * clearance:g} mm above the ground over mid-swing:" if clearance
                      else "free to skim the ground:"))
        out.append("")
        out.append("| t_land [s] | 25 ms mesh [N] | IPOPT | 50 ms mesh [N] | change | landed ahead [mm] "
                   "| stance ankle, largest [rad] | landed-foot drift, 50 → 25 ms mesh [mm] |")
        out.append("|---|---|---|---|---|---|---|---|")
        for p in pts:
            status = _IPOPT_WORDS.get(p["status"], f"stopped: {p['status']}")
            if p["ok"] and not is_step_forward(p["ok"], p["landing"]):
                status += ", the step in place"
            elif p["ok"] and abs(p["rel_change_mesh"]) >= ONE_STEP_MESH_TOL:
                status += ", the meshes disagree"
            out.append(f"| {p['t_land']:.2f} | {p['f_peak']:.2f} | {status} | {p['f_peak_coarse']:.2f} "
                       f"| {100 * p['rel_change_mesh']:+.2f} % | {1000 * p['landing']:.0f} | {p['max_stance_ankle']:.2f} "
                       f"| {1000 * p['landed_drift_coarse']:.1f} → {1000 * p['landed_drift']:.1f} |".replace("-", "−"))
        out.append("")
    return "\n".join(out).rstrip("\n")


def optimum_table(data: dict | None = None) -> str:
    """The cached flat-footed optimum (docs/capability.md section 8) as markdown tables: per duration
    against the LIP bound (50 ms rises, back and chest), the slow pushes (1 s ramps), the heights
    (1 s pushes; these two on the back, as their sweeps push), and the static optimum of the same model against the sustained-push limit."""
    data = load_optimum() if data is None else data
    P = data["parameters"]
    r0 = robot_from_plant_params(P)
    h0 = P["h_push"]
    out = []

    def table(rise, h, head):
        ds = sorted({x["duration"] for x in data["points"] if x["rise"] == rise and x["height"] == h})
        dirs = sorted({x["direction"] for x in data["points"] if x["rise"] == rise and x["height"] == h}, reverse=True)
        lines = [f"| {head} | " + " | ".join(f"{d:g}" for d in ds) + " |", "|---|" + "---|" * len(ds)]
        r = dataclasses.replace(r0, h=h)
        for d in dirs:
            side = "back" if d > 0 else "chest"
            opt = flat_footed_optimum(ds, rise, d, h, data=data)
            lip = lip_force_limit(r, ds, rise, d)
            lines.append(f"| flat-footed optimum, {side} [N] | " + " | ".join(f"{x:.2f}" for x in opt) + " |")
            lines.append(f"| LIP bound, {side} [N] | " + " | ".join(f"{x:.2f}" for x in lip) + " |")
            lines.append(f"| optimum / LIP bound, {side} | " + " | ".join(f"{a / b:.2f}" for a, b in zip(opt, lip)) + " |")
        return "\n".join(lines)

    out.append(table(0.05, h0, f"duration [s] (50 ms rise, h = {h0:g} m)"))
    out.append(table(1.0, h0, f"duration [s] (1 s ramps, h = {h0:g} m)"))
    hs = sorted({x["height"] for x in data["points"] if x["duration"] == 1.0 and x["rise"] == 0.05})
    lines = ["| height [m] (1 s pushes, 50 ms rise) | " + " | ".join(f"{h:g}" for h in hs) + " |", "|---|" + "---|" * len(hs)]
    for d, side in ((1, "back"),):
        lines.append(f"| flat-footed optimum, {side} [N] | "
                     + " | ".join(f"{flat_footed_optimum(1.0, 0.05, d, h, data=data):.2f}" for h in hs) + " |")
        lines.append(f"| static tipping force, {side} [N] | "
                     + " | ".join(f"{static_tipping_force(dataclasses.replace(r0, h=h), d):.2f}" for h in hs) + " |")
    out.append("\n".join(lines))
    st = data.get("static", {})
    if st:
        lines = ["| a push that never ends | back | chest |", "|---|---|---|"]
        lines.append("| static optimum of the model [N] | " + " | ".join(f"{st[k]['nonlinear']:.2f}" for k in ("1", "-1")) + " |")
        lines.append("| the same, moment arm held at h [N] | " + " | ".join(f"{st[k]['rigid_height']:.2f}" for k in ("1", "-1")) + " |")
        lines.append("| sustained-push limit (section 3) [N] | " + " | ".join(f"{sustained_push_limit(r0, d):.2f}" for d in (1, -1)) + " |")
        out.append("\n".join(lines))
    return "\n\n".join(out)

# ---------------------------------------------------------------------------------------------
# N-step capturability of the linear inverted pendulum with a finite foot (Koolen, de Boer, Smith,
# Pratt, Hutter, "Capturability-based analysis and control of legged locomotion, Part 1", IJRR 31(9)
# 2012, section 5): the instantaneous capture point at most d_N ahead of the stance ankle is
# capturable in N steps, each at most l_max long and at least dt_s after the previous one.

def capture_margin(r_max: float, l_max: float, omega: float, dt_s: float, steps,
                   dt_first: float | None = None) -> np.ndarray | float:
    """d_N [m], the largest distance of the instantaneous capture point ahead of the ankle from which the
    LIP with a foot (the CoP up to r_max ahead of the ankle) comes to rest in N = steps steps
    (Koolen et al. 2012, section 5): d_0 = r_max, d_N = (d_{N-1} - r_max + l_max) e^(-omega dt_s) + r_max,
    i.e. d_N = r_max + l_max sum_{k=1..N} e^(-k omega dt_s); steps = inf gives
    d_inf = r_max + l_max e^(-omega dt_s) / (1 - e^(-omega dt_s)). With dt_first the first step lands
    dt_first from now and each next one dt_s after the previous one: the recursion's last stage (the
    first step) takes e^(-omega dt_first), d_N = r_max + l_max e^(-omega dt_first) sum_{k=0..N-1}
    e^(-k omega dt_s). Vectorised over steps."""
    n = np.asarray(steps, float)
    E = math.exp(-omega * dt_s)
    first = E if dt_first is None else math.exp(-omega * dt_first)
    with np.errstate(invalid="ignore"):
        geo = np.where(np.isinf(n), first / (1 - E), first * (1 - E ** np.where(np.isinf(n), 0, n)) / (1 - E))
    out = r_max + l_max * geo
    return float(out) if np.ndim(out) == 0 else out


def n_step_force_limit(r: Robot, duration, rise: float = 0.0, direction: float = +1, steps=1,
                       l_max: float = 0.0, dt_s: float = math.inf, omega: float | None = None,
                       dt_first: float | None = None):
    """Largest peak force [N, magnitude] of a trapezoid push (duration, rise) from which the LIP of the
    ankle strategy (lip_force_limit's pendulum, the CoP at the sole edge from the onset) is
    capturable with `steps` steps of at most l_max [m], the first dt_s [s] after the push onset and
    each next dt_s later (Koolen et al. 2012: d_N of capture_margin with r_max the sole edge's
    effective distance Delta = F_s h/(m_b g), feet included):
    F_N = m_b g d_N / (h omega S), S = integral s(t) e^(-omega t) dt. steps = 0 is lip_force_limit.
    dt_first: the first step lands this long after the onset instead of dt_s (capture_margin).
    Assumes what lip_force_limit assumes, plus Koolen's model: instantaneous steps (no double
    support), the CoP up to Delta ahead of each new ankle, the CoM height unchanged, the push
    continuing whatever the steps. A necessary condition, as lip_force_limit. Vectorised over
    duration (or steps)."""
    w = r.omega if omega is None else omega
    d_n = capture_margin(_edge_moment(r, direction) / r.m_b, l_max, w, dt_s, steps, dt_first)
    return r.g * r.m_b * d_n / (r.h * w * trapezoid_integral(w, duration, rise))


def first_step_deadline(r: Robot, force: float, duration: float, rise: float = 0.0, direction: float = +1,
                        steps=1, l_max: float = 0.0, dt_s: float = math.inf, omega: float | None = None) -> float:
    """The latest landing of the first step [s after the push onset] from which a push of `force` [N]
    (duration, rise) is capturable with `steps` steps (the next ones dt_s apart): the dt_first at which
    n_step_force_limit equals force, from capture_margin's closed form, e^(-omega dt_first) =
    (d - r_max) (1 - E) / (l_max (1 - E^N)), d = force h omega S / (m_b g), E = e^(-omega dt_s).
    inf when the flat foot alone captures it (force <= lip_force_limit), nan when no landing does,
    not even one at the onset (the push needs more than `steps` steps)."""
    w = r.omega if omega is None else omega
    r_max = _edge_moment(r, direction) / r.m_b
    d = abs(force) * r.h * w * float(trapezoid_integral(w, duration, rise)) / (r.g * r.m_b)
    if d <= r_max:
        return math.inf
    E = math.exp(-w * dt_s)
    geo = 1 / (1 - E) if math.isinf(steps) else (1 - E ** steps) / (1 - E)
    x = (d - r_max) / (l_max * geo) if l_max > 0 and steps > 0 else math.inf
    return -math.log(x) / w if x <= 1 else math.nan


def n_step_impulse_limit(r: Robot, direction: float = +1, steps=1, l_max: float = 0.0, dt_s: float = math.inf,
                         omega: float | None = None):
    """Largest impulse [N s] of a very short push capturable in `steps` steps: m_b g d_N / (h omega),
    the limit of n_step_force_limit * duration for duration -> 0 (steps = 0: lip_impulse_limit)."""
    w = r.omega if omega is None else omega
    return r.g * r.m_b * capture_margin(_edge_moment(r, direction) / r.m_b, l_max, w, dt_s, steps) / (r.h * w)


def step_reach(params: dict, hip_drop: float = 0.01) -> tuple[float, float]:
    """HOAP-2's step as the N-step bounds see it, from the robot's numbers: (l_max [m], dt_s [s]).
    The legs (thigh + shank, the header's THIGH and SHANK) stand on flat feet with the pelvis lowered
    by hip_drop from its straight-legged height (the knees bend; the LIP's CoM height changes by
    that much at most): each leg then reaches sqrt(L^2 - (L - hip_drop)^2) forward or back of the hip,
    so the ankles can be l_max = 2 sqrt(L^2 - (L - hip_drop)^2) apart, provided the leg's pitch
    asin(l_max/2/L) is inside the ankle and hip pitch ranges (ValueError otherwise). The swing leg
    turns by twice that pitch at no more than the hip servo's velocity limit (vel_max_hip):
    dt_s = 2 asin(l_max/(2L)) / vel_max_hip, a lower bound of the step time (lift-off, weight shift
    and touch-down take more). Both optimistic, as a bound must be."""
    L = float(params["thigh"]) + float(params["shank"])
    reach = math.sqrt(L * L - (L - hip_drop) ** 2)
    pitch = math.asin(reach / L)
    for k in ("ankle_max", "hip_max"):
        if k in params and pitch > float(params[k]):
            raise ValueError(f"step_reach: leg pitch {pitch:.3f} rad beyond {k} = {float(params[k]):.3f} rad "
                             f"(hip_drop {hip_drop:g} m)")
    for k in ("ankle_min", "hip_min"):
        if k in params and -pitch < float(params[k]):
            raise ValueError(f"step_reach: leg pitch {-pitch:.3f} rad beyond {k} = {float(params[k]):.3f} rad")
    return 2 * reach, 2 * pitch / float(params["vel_max_hip"])


def sustained_push_limit_stepped(r: Robot, l_max: float, direction: float = +1) -> float:
    """sustained_push_limit after a step of l_max along the push: the support polygon l_max longer
    (the stepping foot, half the feet's mass, l_max ahead), the ZMP at its far edge and the body CoM
    at its near one: F h = g [m_b (x_toe - x_heel + l_max) + m_f (x_toe + l_max - x_f - l_max/2)]
    (mirrored on the chest). Assumes what sustained_push_limit assumes."""
    if direction >= 0:
        m = r.m_b * (r.x_toe - r.x_heel + l_max) + r.m_f * (r.x_toe + l_max / 2 - r.x_f)
    else:
        m = r.m_b * (r.x_toe - r.x_heel + l_max) + r.m_f * (r.x_f - r.x_heel + l_max / 2)
    return r.g * m / r.h


STEP_COUNTS = (0, 1, 2, 3, math.inf)


def n_step_table(params: dict, durations=None, rise: float = 0.05, hip_drop: float = 0.01) -> str:
    """The N-step bounds of the nominal robot (docs/capability.md section 9) as markdown: HOAP-2's step
    (step_reach), the capture margins d_N, the impulse limits and the force limits of the sweeps'
    pushes on the back and the chest for N = 0 (the LIP bound), 1, 2, 3 and infinitely many steps."""
    durations = NOMINAL_DURATIONS if durations is None else durations
    r = robot_from_plant_params(params)
    l_max, dt_s = step_reach(params, hip_drop)
    head = ["quantity"] + [("∞ steps" if math.isinf(n) else f"{n} step" + ("s" if n != 1 else "")) for n in STEP_COUNTS]
    out = [f"HOAP-2's step (hip lowered {1000 * hip_drop:g} mm): l_max = {1000 * l_max:.1f} mm, "
           f"dt_s = {1000 * dt_s:.0f} ms; ω = {r.omega:.3f} s⁻¹.", "",
           "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for d, side in ((1, "back"), (-1, "chest")):
        rm = _edge_moment(r, d) / r.m_b
        out.append(f"| capture margin d_N, {side} [mm] | "
                   + " | ".join(f"{1000 * capture_margin(rm, l_max, r.omega, dt_s, n):.1f}" for n in STEP_COUNTS) + " |")
        out.append(f"| impulse limit, {side} [N·s] | "
                   + " | ".join(f"{n_step_impulse_limit(r, d, n, l_max, dt_s):.3f}" for n in STEP_COUNTS) + " |")
        for D in durations:
            out.append(f"| {D:g} s push, {side} [N] | "
                       + " | ".join(f"{float(n_step_force_limit(r, D, rise, d, n, l_max, dt_s)):.1f}" for n in STEP_COUNTS)
                       + " |")
        out.append(f"| sustained-push limit, {side} [N] | {sustained_push_limit(r, d):.2f} | "
                   + " | ".join(f"{sustained_push_limit_stepped(r, l_max, d):.2f}" for _ in STEP_COUNTS[1:]) + " |")
    return "\n".join(out)


FIRST_LANDINGS = (None, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7)


def step_timing_table(params: dict, duration: float = 1.0, rise: float = 0.05, hip_drop: float = 0.01,
                      landings=FIRST_LANDINGS) -> str:
    """When the first step must land (docs/capability.md section 9.2): the N-step force limit of a back
    push of `duration` against the first step's landing after the onset (None: dt_s, the table of
    section 9), the next steps dt_s apart, and the latest first landing that captures a push at the
    flat-footed sustained-push limit (first_step_deadline)."""
    r = robot_from_plant_params(params)
    l_max, dt_s = step_reach(params, hip_drop)
    counts = STEP_COUNTS[1:3] + STEP_COUNTS[-1:]
    head = ["first step lands after the onset [ms]"] + [
        ("∞ steps" if math.isinf(n) else f"{n} step" + ("s" if n != 1 else "")) + " [N]" for n in counts]
    out = [f"{duration:g} s back push ({1000 * rise:g} ms ramps), l_max = {1000 * l_max:.1f} mm, the steps after the "
           f"first dt_s = {1000 * dt_s:.0f} ms apart; 0 steps (the LIP bound): "
           f"{float(lip_force_limit(r, duration, rise, 1)):.1f} N.", "",
           "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for t in landings:
        first = dt_s if t is None else t
        out.append(f"| {1000 * first:.0f} | " + " | ".join(
            f"{float(n_step_force_limit(r, duration, rise, 1, n, l_max, dt_s, dt_first=first)):.1f}" for n in counts)
            + " |")
    f_s = sustained_push_limit(r, 1)
    out.append(f"| latest landing for {f_s:.1f} N (the sustained-push limit) [ms] | " + " | ".join(
        f"{1000 * first_step_deadline(r, f_s, duration, rise, 1, n, l_max, dt_s):.0f}" for n in counts) + " |")
    return "\n".join(out)


@dataclass(frozen=True)
class SideSteps:
    """One step sideways toward a capture point beyond an outer sole edge (docs/capability.md section
    9.1), pushed toward +y (the left foot loaded), y from the mid-plane [m], times [s]. The loaded-leg
    side step stands on the right foot (ankle at -ankle_y, its CoP up to its inner edge, r_max =
    half the sole) while the left swings out, landing at most `width` from the right ankle: the
    pelvis over the mid-plane, the stance leg vertical, the swing leg (thigh + shank) rolled out to
    the hip's abduction limit, width = hip_y + ankle_y + L sin(abduction_max), in dt_min =
    abduction_max / vel_max_hip at the hip servo's speed. The crossover stands on the left foot (its
    CoP up to its outer edge) while the right leg crosses: within the hip's adduction limit its ankle
    gets at most cross_ankle = -hip_y + L sin(adduction_max) from the mid-plane. Koolen's one-step
    margin d_1 = r_max + l_max e^(-omega dt) (capture_margin) about the stance ankle gives the largest
    capture point y that comes to rest. Optimistic as a bound must be: omega the rigid body's about
    the ankle (the smallest of the module's), the CoP moved to the far foot at once, no lift-off or
    touch-down time, the feet's collision ignored."""
    omega: float
    ankle_y: float
    half_sole: float
    width: float
    dt_min: float
    cross_ankle: float

    @property
    def flat(self) -> float:
        """Flat-footed: the capture point at most at the outer sole edge."""
        return self.ankle_y + self.half_sole

    def side_step(self, dt: float) -> float:
        """The loaded-leg side step landing dt after the decision."""
        return -self.ankle_y + capture_margin(self.half_sole, self.width, self.omega, dt, 1)

    def crossover(self, dt: float) -> float:
        """The crossover landing dt after the decision (no gain while the crossing ankle cannot get
        beyond the stance ankle)."""
        return self.ankle_y + capture_margin(self.half_sole, max(self.cross_ankle - self.ankle_y, 0.0), self.omega, dt, 1)

    @property
    def break_even(self) -> float:
        """The side step gains over flat-footed only landing sooner than ln(width / 2 ankle_y) / omega."""
        return math.log(self.width / (2 * self.ankle_y)) / self.omega


def side_steps(params: dict) -> SideSteps:
    """SideSteps of the robot of bounds_parameters' numbers (the header's legs, hip and stance, the
    plant's hip servo speed)."""
    st = stance_from_params(params)
    L = float(params["thigh"]) + float(params["shank"])
    hip_y, abd = float(params["hip_y"]), float(params["hip_abduction_max"])
    return SideSteps(omega=st.body.omega, ankle_y=st.ankle_y, half_sole=st.sole_width / 2,
                     width=hip_y + st.ankle_y + L * math.sin(abd), dt_min=abd / float(params["vel_max_hip"]),
                     cross_ankle=-hip_y + L * math.sin(float(params["hip_adduction_max"])))


def side_step_table(params: dict, swing_times=(0.15, 0.2)) -> str:
    """side_steps' numbers (docs/capability.md section 9.1) as markdown, the side step landing at
    the servo-limited dt_min and at the swing times given."""
    s = side_steps(params)
    out = [f"Sideways (pushed toward +y; ω = {s.omega:.3f} s⁻¹): the loaded-leg side step lands at most "
           f"{1000 * s.width:.1f} mm from the right ankle, its hip rolling out in dt ≥ {1000 * s.dt_min:.0f} ms; "
           f"the crossing right ankle gets at most {1000 * s.cross_ankle:+.1f} mm from the mid-plane "
           f"(the left ankle at {1000 * s.ankle_y:+.1f} mm).", "",
           "| strategy | stance foot | landing after [ms] | capture point's largest y [mm] | against flat-footed [mm] |",
           "|---|---|---|---|---|",
           f"| flat-footed (both feet) | both | – | {1000 * s.flat:.1f} | 0 |"]
    for t in (s.dt_min,) + tuple(swing_times):
        y = s.side_step(t)
        out.append(f"| side step, loaded (left) leg | right | {1000 * t:.0f} | {1000 * y:.1f} | {1000 * (y - s.flat):+.1f} |")
    y = s.crossover(s.dt_min)
    out.append(f"| crossover, unloaded (right) leg | left | {1000 * s.dt_min:.0f} | {1000 * y:.1f} | {1000 * (y - s.flat):+.1f} |")
    out += ["", f"The side step gains only landing within ln(W / 2 ankle_y) / ω = {1000 * s.break_even:.0f} ms "
            "of the decision."]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# every horizontal direction: the robot on both feet (docs/capability.md section 7)

def push_direction(angle):
    """(cos, sin) of a push direction in degrees (0 forward, on the back; 90 toward +y, the left; 180 on
    the chest), exact at multiples of 90 deg: a push at 180 deg has no y component at all. Vectorised."""
    a = np.mod(np.asarray(angle, float), 360.0)
    q = a / 90.0
    k = np.round(q).astype(int) % 4
    exact = q == np.round(q)
    c = np.where(exact, np.array([1.0, 0.0, -1.0, 0.0])[k], np.cos(np.radians(a)))
    s = np.where(exact, np.array([0.0, 1.0, 0.0, -1.0])[k], np.sin(np.radians(a)))
    return c, s


@dataclass(frozen=True)
class Stance:
    """The robot standing erect on both feet, as the bounds in every direction see it (SI).

    `body` is the sagittal Robot (its masses, heights, pitch inertias, feet, sole from x_heel to x_toe
    and the push height). x is forward from the ankle axes, y left from the mid-plane. The soles,
    each sole_width wide, are centred under the ankles at y = +-ankle_y. The erect body CoM is at
    (x_b, y_b) (x_b = 0: over the ankle axes, as the Robot has it), the feet's at (body.x_f, y_f).
    l1 and I1_roll are the legs' length and their roll inertia (both legs, each about its own CoM)
    for the lateral pendulum; roll_max, the largest leg roll the joints allow the parallelogram, only
    for parallelogram_reach."""
    body: Robot
    l1: float
    I1_roll: float
    ankle_y: float
    sole_width: float
    x_b: float = 0.0
    y_b: float = 0.0
    y_f: float = 0.0
    roll_max: float = math.inf

    @property
    def y_edge(self) -> float:
        """The outer sole edges' distance from the mid-plane [m]."""
        return self.ankle_y + self.sole_width / 2

    def polygon(self) -> np.ndarray:
        """The support polygon, counter-clockwise from the front right corner: the convex hull of the
        two soles, which for two equal soles side by side is the rectangle x_heel..x_toe x
        -y_edge..y_edge."""
        b, w = self.body, self.y_edge
        return np.array([[b.x_toe, -w], [b.x_toe, w], [b.x_heel, w], [b.x_heel, -w]])

    @property
    def com(self) -> tuple[float, float]:
        """The erect robot's CoM (feet included) on the ground: (x, y) [m]."""
        b = self.body
        return ((b.m_b * self.x_b + b.m_f * b.x_f) / b.m_tot, (b.m_b * self.y_b + b.m_f * self.y_f) / b.m_tot)

    @property
    def k_y(self) -> float:
        """Sideways travel of the body CoM per radian of leg roll in the parallelogram [m]:
        (m1 lg1 + m2 l1) / m_b (the legs' CoMs move lg1 phi, the upper body l1 phi)."""
        b = self.body
        return (b.m1 * (b.z1 - b.ankle_height) + b.m2 * self.l1) / b.m_b

    @property
    def omega_y(self) -> float:
        """LIP rate [1/s] of the lateral motion in double support (the bounds use it): the legs roll by
        phi about their ankles, the pelvis and the upper body translate by l1 phi without rolling (the
        parallelogram), the feet stay. Angular momentum about a ground point p, linearised:
        (m2 z2 l1 + m1 z1 lg1 + I1_roll) phi'' = m_b g (y - p) + m_f g (y_f - p) + F_y h with
        y = k_y phi, so omega_y^2 = m_b g k_y / (m2 z2 l1 + m1 z1 lg1 + I1_roll)."""
        b = self.body
        lg1 = b.z1 - b.ankle_height
        return math.sqrt(b.m_b * b.g * self.k_y / (b.m2 * b.z2 * self.l1 + b.m1 * b.z1 * lg1 + self.I1_roll))

    @property
    def parallelogram_reach(self) -> float:
        """How far sideways the parallelogram alone can carry the body CoM within roll_max [m]."""
        return self.k_y * math.sin(min(self.roll_max, math.pi / 2))

    def axis(self, k: str) -> tuple[Robot, float]:
        """The bounds' 1D problem along "x" or "y": a Robot whose x is that axis measured from the erect
        body CoM (its toe and heel the polygon's edges ahead of and behind it, on y the left and right
        outer sole edges; its x_f the feet's CoM), and the pendulum rate on that axis."""
        b = self.body
        if k == "x":
            return (dataclasses.replace(b, x_toe=b.x_toe - self.x_b, x_heel=b.x_heel - self.x_b, x_f=b.x_f - self.x_b),
                    b.omega)
        w = self.y_edge
        return dataclasses.replace(b, x_toe=w - self.y_b, x_heel=-w - self.y_b, x_f=self.y_f - self.y_b), self.omega_y


def _per_axis(st: Stance, angle, fn):
    """min over the axes of fn(axis robot, direction, omega) / |the push's component on the axis|: the
    push direction's bound when each axis must hold its own component (an axis without one: no limit)."""
    c, s = push_direction(angle)
    out = None
    with np.errstate(divide="ignore"):
        for k, comp in (("x", c), ("y", s)):
            r, w = st.axis(k)
            v = np.where(comp >= 0, fn(r, +1, w), fn(r, -1, w)) / np.abs(comp)
            out = v if out is None else np.minimum(out, v)
    return float(out) if np.ndim(out) == 0 else out


def static_tipping_force_3d(st: Stance, angle):
    """Constant push [N] in the direction `angle` [deg] that tips the erect rigid robot over the support
    polygon. The centre of pressure sits at the CoM's projection c moved by F h/(M g) along the push;
    the robot tips when it reaches the polygon's boundary, about the edge the ray from c meets first
    (a corner where it meets one): by moment balance about each edge the push points at,
    F h (u . n) = M g (distance of c from the edge), the smallest of these F. On the rectangle:
    min over x, y of the sagittal static_tipping_force of that axis / |cos| or |sin|. Feet included;
    assumes what static_tipping_force assumes. Vectorised over angle."""
    return _per_axis(st, angle, lambda r, d, w: static_tipping_force(r, d))


def sustained_push_limit_3d(st: Stance, angle):
    """Largest constant push [N] in the direction `angle` [deg] that any flat-footed strategy can hold:
    statics, M g p = m_b g c_b + m_f g c_f + F h u with the centre of pressure p and the body CoM c_b
    both in the polygon (the robot must still stand when the push stops) and the feet where they
    are. On the rectangle the two axes are independent: p at the edges the push points at, c_b at
    the opposite ones, F = min over x, y of the sagittal sustained_push_limit / |cos| or |sin|.
    Assumes: small angles (h unchanged), feet flat and held down by their weight, friction enough,
    no joint limits (see Stance.parallelogram_reach). Vectorised over angle."""
    return _per_axis(st, angle, lambda r, d, w: sustained_push_limit(r, d))


def lip_force_limit_3d(st: Stance, angle, duration, rise: float = 0.0):
    """Largest peak force [N] of a trapezoid push (duration, rise, see trapezoid_integral) in the
    direction `angle` [deg] after which a CoP-only (ankle) strategy can still be capturable. The
    linearised sagittal and lateral motions are decoupled, each a pendulum of its own rate (the
    ankle pitch's omega on x, the parallelogram's omega_y on y), and the polygon's x and y ranges
    are independent, so the best CoP sits at the corner the push points at from the onset and each
    axis must capture its own component: min over x, y of lip_force_limit of that axis / |cos| or
    |sin|. Assumes what lip_force_limit assumes, per axis. Vectorised over angle (or duration)."""
    return _per_axis(st, angle, lambda r, d, w: lip_force_limit(r, duration, rise, d, w))


def lip_impulse_limit_3d(st: Stance, angle):
    """Largest impulse [N s] of a very short push in the direction `angle` [deg] a CoP-only strategy
    can absorb: min over x, y of lip_impulse_limit of that axis / |cos| or |sin|."""
    return _per_axis(st, angle, lambda r, d, w: lip_impulse_limit(r, d, w))


def tipping_edge(st: Stance, angle: float) -> str:
    """Which part of the polygon the erect robot tips over under a push in the direction `angle` [deg]:
    toe, heel, left or right edge, or the corner between two (within 1e-9 of both)."""
    c, s = (float(x) for x in push_direction(angle))
    cand = []
    for k, comp, names in (("x", c, ("toe", "heel")), ("y", s, ("left", "right"))):
        if comp != 0:
            r, _ = st.axis(k)
            cand.append((static_tipping_force(r, comp) / abs(comp), names[0] if comp > 0 else names[1]))
    f = min(x for x, _ in cand)
    hit = [n for x, n in cand if x <= f * (1 + 1e-9)]
    return hit[0] + " edge" if len(hit) == 1 else f"{hit[0]}-{hit[1]} corner"


# The generated header's names of the numbers the bounds read (hoap2/include/hoap2/nominal.h, HOAP2_<NAME>),
# by the plant parameter's name where a plant has one.
HEADER_NAMES = {"g": "G", "m1": "M1", "l1": "L1", "lg1": "LG1", "I1": "I1", "m2": "M2", "lg2": "LG2", "I2": "I2",
                "feet_mass": "FEET_MASS", "feet_com_x": "FEET_COM_X", "toe_x": "TOE_X", "heel_x": "HEEL_X",
                "ankle_height": "ANKLE_HEIGHT", "ankle_y": "ANKLE_Y", "sole_width": "SOLE_WIDTH",
                "I1_roll": "I1_ROLL", "link2_com_y": "LINK2_COM_Y", "ankle_roll_max": "ANKLE_ROLL_MAX",
                "hip_abduction_max": "HIP_ABDUCTION_MAX", "hip_adduction_max": "HIP_ADDUCTION_MAX",
                "ankle_min": "ANKLE_MIN", "ankle_max": "ANKLE_MAX", "hip_min": "HIP_MIN", "hip_max": "HIP_MAX",
                "thigh": "THIGH", "shank": "SHANK", "hip_y": "HIP_Y"}


def header_numbers(text: str) -> dict[str, float]:
    """The numbers of the generated header (hoap2/nominal.h) by their macro name without HOAP2_ (the
    literal ones; the derived macros are expressions and are left out)."""
    import re
    return {m[1]: float(m[2]) for m in re.finditer(r"^#define HOAP2_(\w+) \(?(-?[0-9.eE+-]+)\)?$", text, re.M)}


def plant_header(unzipdir) -> dict[str, float]:
    """header_numbers of the robot header a plant FMU was built from: its sources/hoap2/nominal.h
    (both plant FMUs are source FMUs and carry it); {} when the FMU has none."""
    from pathlib import Path
    p = Path(unzipdir) / "sources" / "hoap2" / "nominal.h"
    return header_numbers(p.read_text()) if p.is_file() else {}


def bounds_parameters(plant_values: dict, header: dict[str, float]) -> dict[str, float]:
    """The numbers the bounds read, by the plant parameters' names: the plant's (its parameters' and
    constants' start values with any overrides, e.g. Hoap2Plant's m1 or Hoap2Plant3D's h_push and
    link CoM offsets) and, for what the plant does not publish (the 3D plant's masses, the stance
    width, the roll inertias), the generated header's (header_numbers)."""
    out = {k: header[m] for k, m in HEADER_NAMES.items() if m in header}
    out.update({k: float(v) for k, v in plant_values.items() if isinstance(v, (int, float)) and not isinstance(v, bool)})
    return out


def erect_body_com_x(r: Robot, l1: float, d1: float, d2: float, theta_ankle: float, theta_hip: float) -> float:
    """The body CoM's x [m] in the posture (theta_ankle, theta_hip) of the sagittal angles (+ forward;
    the hip relative to the leg) when the links' CoMs lie d1 (legs) and d2 (upper body) ahead of their
    joint lines: x1 = lg1 sin t1 + d1 cos t1, x2 = l1 sin t1 + lg2 sin t12 + d2 cos t12. The
    controller's erect posture (docs/controller.md section 2.1) makes it 0 for the offsets it knows."""
    lg1, lg2 = r.z1 - r.ankle_height, r.z2 - r.ankle_height - l1
    t1, t12 = theta_ankle, theta_ankle + theta_hip
    x1 = lg1 * math.sin(t1) + d1 * math.cos(t1)
    x2 = l1 * math.sin(t1) + lg2 * math.sin(t12) + d2 * math.cos(t12)
    return (r.m1 * x1 + r.m2 * x2) / r.m_b


def stance_from_params(params: dict, theta_ankle: float = 0.0, theta_hip: float = 0.0) -> Stance:
    """A Stance from bounds_parameters' numbers, standing in the posture (theta_ankle, theta_hip): the
    sagittal Robot (robot_from_plant_params), the stance width, leg length and roll inertia, the
    body CoM's x from the links' CoM offsets (the plant's constants link1_com_x, link2_com_x; 0 for a
    plant whose links carry their CoMs on the joint lines, as Hoap2Plant's) in that posture, its y
    from link 2's (the legs are mirror images: their offsets cancel), the feet's y on the mid-plane,
    and the parallelogram's largest roll from the ankle-roll and hip ab/adduction limits."""
    r = robot_from_plant_params(params)
    p = {k: float(v) for k, v in params.items() if isinstance(v, (int, float))}
    d1, d2 = p.get("link1_com_x", 0.0), p.get("link2_com_x", 0.0)
    roll = min(p.get(k, math.inf) for k in ("ankle_roll_max", "hip_abduction_max", "hip_adduction_max"))
    return Stance(body=r, l1=p["l1"], I1_roll=p["I1_roll"], ankle_y=p["ankle_y"], sole_width=p["sole_width"],
                  x_b=erect_body_com_x(r, p["l1"], d1, d2, theta_ankle, theta_hip),
                  y_b=r.m2 * p.get("link2_com_y", 0.0) / r.m_b, roll_max=roll)


NOMINAL_DURATIONS = (0.1, 0.15, 0.2, 0.3, 0.5, 1.0, 2.0, 4.0)   # scenarios/sweeps/force_duration.toml


def nominal_table(params: dict, durations=NOMINAL_DURATIONS, rise: float = 0.05) -> str:
    """The numbers of docs/capability.md as a markdown table."""
    r = robot_from_plant_params(params)

    def both(fn, fmt, unit):     # back / chest
        return f"{fn(r, 1):{fmt}} / {fn(r, -1):{fmt}} {unit}"

    rows = [("m_b = m1 + m2 (body)", f"{r.m_b:.4f} kg"), ("m_f (feet)", f"{r.m_f:.4f} kg"),
            ("x_f (feet CoM)", f"{1000 * r.x_f:.2f} mm"), ("x_toe", f"{1000 * r.x_toe:.1f} mm"),
            ("x_heel", f"{1000 * r.x_heel:.1f} mm"), ("h (push height)", f"{r.h:.3f} m"),
            ("z_b (body CoM above the sole)", f"{r.z_b:.4f} m"), ("I_b (body, about its CoM)", f"{r.I_b:.4f} kg·m²"),
            ("I_ankle (body, about the ankle axis)", f"{r.I_ankle:.4f} kg·m²"),
            ("I_s (body, about the sole point)", f"{r.I_sole:.4f} kg·m²"),
            ("ω, rigid body about the ankle (used)", f"{r.omega:.3f} s⁻¹"),
            ("ω, rigid body about the sole point", f"{r.omega_sole:.3f} s⁻¹"),
            ("ω, point mass √(g/z_b)", f"{r.omega_point:.3f} s⁻¹"),
            ("static tipping force, back / chest", both(static_tipping_force, ".2f", "N")),
            ("sustained-push limit, back / chest", both(sustained_push_limit, ".2f", "N")),
            ("LIP impulse limit, back / chest", both(lip_impulse_limit, ".3f", "N·s"))]
    fb, fc = lip_force_limit(r, durations, rise, 1), lip_force_limit(r, durations, rise, -1)
    for d, a, b in zip(durations, fb, fc):
        rows.append((f"LIP force limit, {d:g} s push ({1000 * rise:g} ms rise), back / chest", f"{a:.2f} / {b:.2f} N"))
    return "\n".join(["| quantity | value |", "|---|---|"] + [f"| {q} | {v} |" for q, v in rows])


NOMINAL_ANGLES = tuple(range(0, 360, 30))      # scenarios/sweeps/polar_3d.toml
POLAR_DURATIONS = (1.0, 0.2)                    # its pulses


def stance_table(st: Stance) -> str:
    """The stance's numbers (docs/capability.md section 7) as a markdown table."""
    b = st.body
    cx, cy = st.com
    rows = [("ankles across (ankle_y), sole width", f"±{1000 * st.ankle_y:.1f} mm, {1000 * st.sole_width:.1f} mm"),
            ("support polygon", f"x {1000 * b.x_heel:.1f} … {1000 * b.x_toe:.1f} mm, y ±{1000 * st.y_edge:.1f} mm"),
            ("erect body CoM (x_b, y_b)", f"{1000 * st.x_b:.2f} mm, {1000 * st.y_b:.2f} mm"),
            ("erect robot CoM on the ground (feet included)", f"{1000 * cx:.2f} mm, {1000 * cy:.2f} mm"),
            ("k_y: body CoM travel per radian of leg roll", f"{1000 * st.k_y:.1f} mm"),
            ("ω_x, rigid body pitching about the ankles (sagittal)", f"{b.omega:.3f} s⁻¹"),
            ("ω_y, the double-support parallelogram (lateral)", f"{st.omega_y:.3f} s⁻¹"),
            ("ω, point mass √(g/z_b)", f"{b.omega_point:.3f} s⁻¹"),
            ("largest leg roll of the parallelogram (joint limits)", f"{st.roll_max:.4f} rad"),
            ("body CoM reach of the parallelogram sideways", f"{1000 * st.parallelogram_reach:.1f} mm")]
    return "\n".join(["| quantity | value |", "|---|---|"] + [f"| {q} | {v} |" for q, v in rows])


def direction_table(st: Stance, angles=NOMINAL_ANGLES, durations=POLAR_DURATIONS, rise: float = 0.05) -> str:
    """The bounds per push direction (docs/capability.md section 7) as a markdown table."""
    head = ["direction [deg]", "tips over", "static [N]", "sustained [N]", "LIP impulse [N·s]"]
    head += [f"LIP, {d:g} s pulse [N]" for d in durations]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for a in angles:
        cells = [f"{a:g}", tipping_edge(st, a), f"{static_tipping_force_3d(st, a):.2f}",
                 f"{sustained_push_limit_3d(st, a):.2f}", f"{lip_impulse_limit_3d(st, a):.3f}"]
        cells += [f"{float(lip_force_limit_3d(st, a, d, rise)):.2f}" for d in durations]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def nominal_tables_3d(params: dict, theta_ankle: float = 0.0, theta_hip: float = 0.0) -> str:
    """stance_table and direction_table of the robot standing in (theta_ankle, theta_hip)."""
    st = stance_from_params(params, theta_ankle, theta_hip)
    return stance_table(st) + "\n\n" + direction_table(st)


if __name__ == "__main__":      # pragma: no cover - prints the doc's tables
    import argparse
    from ..running.fmu import FMUInfo
    from ..files.paths import PLANT_FMU, find_fmu
    from ..files.scenario import Scenario
    from ..running.master import Models
    from ..running.sweep import bounds_parameters_of
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu-dir")
    fmu_dir = ap.parse_args().fmu_dir
    plant = FMUInfo.load(find_fmu(PLANT_FMU, fmu_dir))
    print(nominal_table(plant.start_values()))
    # the 3D plant standing in the default controller's erect posture, as a sweep on it sees it
    p = bounds_parameters_of(Models.load(fmu_dir, plant_model="3d"), Scenario("bounds", None, plant_model="3d"))
    print("\n" + nominal_tables_3d(p, p.get("theta_ankle_erect", 0.0), p.get("theta_hip_erect", 0.0)))
    print("\n" + optimum_table())          # the cached flat-footed optimum (section 8)
    print("\n" + one_step_table())         # the cached one-step optimum (section 9.3)
    sagittal = bounds_parameters(plant.start_values(), plant_header(plant.unzipdir))
    print("\n" + n_step_table(sagittal))        # section 9
    print("\n" + side_step_table(sagittal))     # 9.1
    print("\n" + step_timing_table(sagittal))   # 9.2
