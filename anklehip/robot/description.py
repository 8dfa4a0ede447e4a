"""Robot descriptions (URDF, MJCF) placed in a standing posture: every body's mass, centre of mass
and inertia in the world frame, the joints' axes and limits, and the collision geometry as points.

URDF is read here (the format is small: links with <inertial> and <collision>, joints with
<origin>, <axis>, <limit>); its collision meshes through trimesh (STL, OBJ, and COLLADA with
pycollada). MJCF is compiled by MuJoCo (defaults, compiler settings, inertia from geoms: MuJoCo's
own rules). Pinocchio, which reads both, is kept independent: the tests check the lumps against it.

Frames: the description's root (URDF) or world (MJCF) frame with z up; `forward` says which of its
axes points forward (REP 103: +x).
"""
from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .robotfile import RobotFileError

# A link or site whose name says it is a sole frame (REP 120: l_sole, r_sole; Talos: left_sole_link)
SOLE_NAME = re.compile(r"(^|_)sole(_link|_frame)?$", re.I)


@dataclass
class Joint:
    name: str
    kind: str                      # revolute | continuous | prismatic | fixed | free | ball
    axis: np.ndarray               # world frame, unit (revolute/prismatic)
    anchor: np.ndarray             # a point of the axis, world frame
    q: float = 0.0                 # its value in the posture
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    velocity: float | None = None


@dataclass
class Body:
    name: str
    parent: str | None
    joint: Joint | None            # the joint to the parent (None: the root, or welded)
    mass: float
    com: np.ndarray                # world frame
    inertia: np.ndarray            # 3x3 about the CoM, world axes
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))   # collision geometry, world
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))        # the body frame's origin, world


@dataclass
class Description:
    path: Path
    kind: str                                  # urdf | mjcf
    bodies: dict[str, Body]                    # parents before children
    posture: dict[str, float]                  # joint -> value used
    posture_source: str
    ground_z: float | None = None              # MJCF: a plane in the world body
    ground_source: str = ""
    sole_frames: dict[str, np.ndarray] = field(default_factory=dict)   # name -> world point
    notes: list[str] = field(default_factory=list)

    def children(self, name: str) -> list[str]:
        return [b.name for b in self.bodies.values() if b.parent == name]

    def subtree(self, name: str) -> list[str]:
        out, todo = [], [name]
        while todo:
            n = todo.pop()
            out.append(n)
            todo += self.children(n)
        return out

    def path_to_root(self, name: str) -> list[str]:
        out = [name]
        while self.bodies[out[-1]].parent is not None:
            out.append(self.bodies[out[-1]].parent)
        return out


def rotation(axis, angle: float) -> np.ndarray:
    """Right-handed rotation about a unit axis (Rodrigues)."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(y) Ry(p) Rx(r)."""
    return rotation([0, 0, 1], y) @ rotation([0, 1, 0], p) @ rotation([1, 0, 0], r)


FORWARD = {"+x": np.eye(3), "x": np.eye(3), "-x": rotation([0, 0, 1], math.pi),
           "+y": rotation([0, 0, 1], -math.pi / 2), "y": rotation([0, 0, 1], -math.pi / 2),
           "-y": rotation([0, 0, 1], math.pi / 2)}


def forward_rotation(forward: str) -> np.ndarray:
    """The rotation about z that turns the description's forward axis into +x (x forward, y left)."""
    try:
        R = FORWARD[forward]
    except KeyError:
        raise RobotFileError(f"--forward {forward}: must be one of +x, -x, +y, -y") from None
    return np.round(R, 15)     # exact 0/1 entries


def load_description(path: str | Path, posture: dict[str, float] | None = None, keyframe: str | None = None,
                     srdf: str | Path | None = None, forward: str = "+x",
                     package_dirs: dict[str, str] | None = None) -> Description:
    """The description at `path` (URDF or MJCF, by its root element) in a standing posture:
    `keyframe` (MJCF <key name>, or an SRDF <group_state name> with `srdf`), then `posture`
    (joint -> value, on top), all other joints at 0 (MJCF: qpos0)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except OSError as e:
        raise RobotFileError(f"{path}: cannot read: {e.strerror}") from None
    except ET.ParseError as e:
        raise RobotFileError(f"{path}: not XML: {e}") from None
    if root.tag == "robot":
        if keyframe and not srdf:
            raise RobotFileError(f"{path}: --keyframe {keyframe}: a URDF names its postures in an SRDF: give --srdf FILE")
        q = dict(srdf_posture(srdf, keyframe)) if keyframe else {}
        src = f"SRDF {srdf} group_state {keyframe!r}" if keyframe else "all joints 0"
        q.update(posture or {})
        if posture:
            src += " + " + ", ".join(f"{k} = {v:g}" for k, v in posture.items())
        d = _load_urdf(path, root, q, src, package_dirs or {})
    elif root.tag == "mujoco":
        if srdf:
            raise RobotFileError(f"{path}: --srdf: an MJCF names its postures in <keyframe>; use --keyframe")
        d = _load_mjcf(path, posture or {}, keyframe)
    else:
        raise RobotFileError(f"{path}: neither URDF (<robot>) nor MJCF (<mujoco>): root element <{root.tag}>")
    _turn(d, forward_rotation(forward))
    return d


def _turn(d: Description, R: np.ndarray) -> None:
    """Express everything in the frame whose x is the robot's forward direction."""
    if np.array_equal(R, np.eye(3)):
        return
    for b in d.bodies.values():
        b.com, b.inertia, b.origin = R @ b.com, R @ b.inertia @ R.T, R @ b.origin
        b.points = b.points @ R.T
        if b.joint is not None:
            b.joint.axis, b.joint.anchor = R @ b.joint.axis, R @ b.joint.anchor
    d.sole_frames = {k: R @ v for k, v in d.sole_frames.items()}


def srdf_posture(srdf: str | Path | None, name: str) -> dict[str, float]:
    """The joint values of an SRDF <group_state name=...>."""
    where = str(srdf)
    try:
        root = ET.parse(srdf).getroot()
    except OSError as e:
        raise RobotFileError(f"{where}: cannot read: {e.strerror}") from None
    except ET.ParseError as e:
        raise RobotFileError(f"{where}: not XML: {e}") from None
    states = root.findall("group_state")
    for s in states:
        if s.get("name") == name:
            return {j.get("name"): _float(j.get("value"), f"{where}: group_state {name}: joint {j.get('name')}")
                    for j in s.findall("joint")}
    known = sorted({s.get("name") for s in states})
    raise RobotFileError(f"{where}: no group_state named {name!r} (known: {', '.join(known) or 'none'})")


def _float(text: str | None, where: str, default: float | None = None) -> float:
    if text is None:
        if default is None:
            raise RobotFileError(f"{where}: value missing")
        return default
    try:
        v = float(text)
    except ValueError:
        raise RobotFileError(f"{where}: not a number: {text!r}") from None
    if not math.isfinite(v):
        raise RobotFileError(f"{where}: not finite: {text!r}")
    return v


def _vec(text: str | None, where: str, n: int = 3, default=None) -> np.ndarray:
    if text is None:
        if default is None:
            raise RobotFileError(f"{where}: missing")
        return np.asarray(default, float)
    parts = text.split()
    if len(parts) != n:
        raise RobotFileError(f"{where}: expected {n} numbers, got {text!r}")
    return np.array([_float(p, where) for p in parts])


# ----------------------------------------------------------------------------------------------
# URDF

def _origin(el: ET.Element | None, where: str) -> tuple[np.ndarray, np.ndarray]:
    if el is None:
        return np.eye(3), np.zeros(3)
    xyz = _vec(el.get("xyz"), f"{where} <origin xyz>", default=[0, 0, 0])
    rpy = _vec(el.get("rpy"), f"{where} <origin rpy>", default=[0, 0, 0])
    return rpy_matrix(*rpy), xyz


def _load_urdf(path: Path, root: ET.Element, posture: dict[str, float], posture_source: str,
               package_dirs: dict[str, str]) -> Description:
    where = str(path)
    links = {}
    for el in root.findall("link"):
        n = el.get("name")
        if not n:
            raise RobotFileError(f"{where}: a <link> without a name")
        if n in links:
            raise RobotFileError(f"{where}: link {n!r} defined twice")
        links[n] = el
    joints = {}
    child_of = {}
    for el in root.findall("joint"):
        n = el.get("name")
        p, c = el.find("parent"), el.find("child")
        if not n or p is None or c is None:
            raise RobotFileError(f"{where}: joint {n!r}: needs a name, <parent link> and <child link>")
        pl, cl = p.get("link"), c.get("link")
        for x in (pl, cl):
            if x not in links:
                raise RobotFileError(f"{where}: joint {n}: unknown link {x!r}")
        if cl in child_of:
            raise RobotFileError(f"{where}: link {cl!r} is the child of two joints ({child_of[cl]}, {n})")
        joints[n] = el
        child_of[cl] = n
    unknown = set(posture) - set(joints)
    if unknown:
        raise RobotFileError(f"{where}: the posture names unknown joints: {', '.join(sorted(unknown))}")
    roots = [n for n in links if n not in child_of]
    if len(roots) != 1:
        raise RobotFileError(f"{where}: a URDF is one tree with one root link, found {len(roots)}: {roots[:5]}")
    children: dict[str, list[str]] = {n: [] for n in links}
    for n, el in joints.items():
        children[el.find("parent").get("link")].append(n)

    bodies: dict[str, Body] = {}
    sole: dict[str, np.ndarray] = {}
    # depth-first from the root: the link frame's pose (R, p) in the root frame
    stack = [(roots[0], None, np.eye(3), np.zeros(3), None)]
    while stack:
        name, parent, R, p, joint = stack.pop()
        el = links[name]
        lw = f"{where}: link {name}"
        mass, com, inertia = 0.0, p.copy(), np.zeros((3, 3))
        inl = el.find("inertial")
        if inl is not None:
            Ri, pi = _origin(inl.find("origin"), lw + " <inertial>")
            m_el, i_el = inl.find("mass"), inl.find("inertia")
            mass = _float(m_el.get("value") if m_el is not None else None, lw + " <mass value>")
            if i_el is None:
                raise RobotFileError(f"{lw}: <inertial> without <inertia>")
            g = {k: _float(i_el.get(k), f"{lw} <inertia {k}>", 0.0) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            I = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]], [g["ixz"], g["iyz"], g["izz"]]])
            com = p + R @ pi
            inertia = (R @ Ri) @ I @ (R @ Ri).T
        pts = [_collision_points(c, R, p, f"{lw} <collision>", path, package_dirs) for c in el.findall("collision")]
        points = np.vstack(pts) if pts else np.zeros((0, 3))
        bodies[name] = Body(name, parent, joint, mass, com, inertia, points, p.copy())
        if SOLE_NAME.search(name):
            sole[name] = p.copy()
        for jn in reversed(children[name]):
            jel = joints[jn]
            jw = f"{where}: joint {jn}"
            kind = jel.get("type", "")
            if kind not in ("revolute", "continuous", "prismatic", "fixed", "floating", "planar"):
                raise RobotFileError(f"{jw}: unknown type {kind!r}")
            Ro, po = _origin(jel.find("origin"), jw)
            Rj, pj = R @ Ro, p + R @ po          # the joint frame
            ax_el = jel.find("axis")
            axis = _vec(ax_el.get("xyz") if ax_el is not None else None, f"{jw} <axis xyz>", default=[1, 0, 0])
            if kind in ("revolute", "continuous", "prismatic") and not np.linalg.norm(axis) > 0:
                raise RobotFileError(f"{jw}: <axis xyz> is zero")
            q = float(posture.get(jn, 0.0))
            if kind in ("floating", "planar") and jn in posture:
                raise RobotFileError(f"{jw}: a {kind} joint cannot take a posture value")
            lim = jel.find("limit")
            lower = upper = effort = velocity = None
            if lim is not None:
                lower = _float(lim.get("lower"), f"{jw} <limit lower>", 0.0)
                upper = _float(lim.get("upper"), f"{jw} <limit upper>", 0.0)
                effort = _float(lim.get("effort"), f"{jw} <limit effort>") if lim.get("effort") else None
                velocity = _float(lim.get("velocity"), f"{jw} <limit velocity>") if lim.get("velocity") else None
            if kind == "continuous":
                lower = upper = None
            a_world = Rj @ (axis / (np.linalg.norm(axis) or 1.0))
            Rc, pc = Rj, pj
            if kind in ("revolute", "continuous"):
                Rc = Rj @ rotation(axis, q)
            elif kind == "prismatic":
                pc = pj + a_world * q
            j = Joint(jn, kind, a_world, pj.copy(), q, lower, upper, effort, velocity)
            stack.append((jel.find("child").get("link"), name, Rc, pc, j))
    return Description(path, "urdf", bodies, dict(posture), posture_source, sole_frames=sole)


def _resolve_mesh(filename: str, urdf: Path, package_dirs: dict[str, str], where: str) -> Path:
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        cands = []
        if pkg in package_dirs:
            cands.append(Path(package_dirs[pkg]) / rest)
        for parent in urdf.resolve().parents:            # the package folder above the URDF
            if parent.name == pkg:
                cands.append(parent / rest)
        for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
            if d:
                cands += [Path(d) / pkg / rest]
        for c in cands:
            if c.is_file():
                return c
        raise RobotFileError(f"{where}: mesh {filename}: package {pkg!r} not found (above the URDF, in "
                             f"ROS_PACKAGE_PATH, or given with --package-dir {pkg}=DIR)")
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    p = Path(filename)
    p = p if p.is_absolute() else urdf.parent / p
    if not p.is_file():
        raise RobotFileError(f"{where}: mesh {filename}: file {p} not found")
    return p


_MESH_CACHE: dict[Path, np.ndarray] = {}


def mesh_hull(path: Path, where: str) -> np.ndarray:
    """The vertices of the convex hull of a mesh file (its own frame, unscaled)."""
    if path not in _MESH_CACHE:
        try:
            import trimesh
        except ImportError:
            raise RobotFileError(f"{where}: reading the mesh {path.name} needs trimesh: "
                                 "pip install 'anklehip[robot]'") from None
        try:
            m = trimesh.load(str(path), force="mesh")
        except Exception as e:    # trimesh raises many kinds for a file it cannot read
            raise RobotFileError(f"{where}: mesh {path}: cannot read it: {type(e).__name__}: {e}") from None
        v = np.asarray(getattr(m, "vertices", np.zeros((0, 3))), float)
        if len(v) == 0:
            raise RobotFileError(f"{where}: mesh {path}: no vertices")
        try:
            v = np.asarray(trimesh.convex.convex_hull(v).vertices, float) if len(v) >= 4 else v
        except Exception:    # a flat or degenerate mesh: its vertices are the hull's
            pass
        if path.suffix.lower() == ".dae":
            v = _collada_frame(path, where) @ v.T
            v = v.T
        _MESH_CACHE[path] = v
    return _MESH_CACHE[path]


def _collada_frame(path: Path, where: str) -> np.ndarray:
    """COLLADA's <asset>: the <unit meter> scale and the rotation from its <up_axis> to z up (the
    COLLADA standard; trimesh, like assimp, leaves both to the caller): Y_UP turns +90 deg about x,
    X_UP -90 deg about y."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise RobotFileError(f"{where}: mesh {path}: not XML: {e}") from None
    ns = root.tag[:root.tag.index("}") + 1] if root.tag.startswith("{") else ""
    asset = root.find(f"{ns}asset")
    scale, up = 1.0, "Y_UP"           # COLLADA's defaults
    if asset is not None:
        u = asset.find(f"{ns}unit")
        if u is not None and u.get("meter"):
            scale = _float(u.get("meter"), f"{where}: mesh {path} <unit meter>")
        a = asset.find(f"{ns}up_axis")
        if a is not None and a.text:
            up = a.text.strip()
    turn = {"Z_UP": np.eye(3), "Y_UP": rotation([1, 0, 0], math.pi / 2),
            "X_UP": rotation([0, 1, 0], -math.pi / 2)}.get(up)
    if turn is None:
        raise RobotFileError(f"{where}: mesh {path}: unknown <up_axis> {up!r}")
    return scale * np.round(turn, 15)


def _circle(n: int = 64) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.stack([np.cos(t), np.sin(t)], axis=1)


def shape_points(kind: str, size: np.ndarray) -> np.ndarray:
    """Points on a primitive's surface whose convex hull is the shape (spheres, cylinders and capsules
    sampled: 64 points a circle), in its own frame (z the axis). size: box full edge lengths;
    sphere (r,); cylinder / capsule (r, length)."""
    if kind == "box":
        s = np.asarray(size, float) / 2
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * s
    if kind == "sphere":
        r = size[0]
        c = _circle()
        ring = [np.column_stack([r * math.cos(a) * c, np.full(len(c), r * math.sin(a))])
                for a in np.linspace(-math.pi / 2, math.pi / 2, 17)[1:-1]]
        return np.vstack(ring + [[[0, 0, -r], [0, 0, r]]])
    if kind in ("cylinder", "capsule"):
        r, h = size[0], size[1]
        c = r * _circle()
        pts = [np.column_stack([c, np.full(len(c), z)]) for z in (-h / 2, h / 2)]
        if kind == "capsule":
            pts += [shape_points("sphere", [r]) + [0, 0, z] for z in (-h / 2, h / 2)]
        return np.vstack(pts)
    raise ValueError(kind)


def _collision_points(el: ET.Element, R: np.ndarray, p: np.ndarray, where: str, urdf: Path,
                      package_dirs: dict[str, str]) -> np.ndarray:
    Ro, po = _origin(el.find("origin"), where)
    geo = el.find("geometry")
    shape = list(geo) if geo is not None else []
    if len(shape) != 1:
        raise RobotFileError(f"{where}: <geometry> must hold one shape")
    s = shape[0]
    if s.tag == "box":
        local = shape_points("box", _vec(s.get("size"), f"{where} <box size>"))
    elif s.tag == "sphere":
        local = shape_points("sphere", [_float(s.get("radius"), f"{where} <sphere radius>")])
    elif s.tag in ("cylinder", "capsule"):
        local = shape_points(s.tag, [_float(s.get("radius"), f"{where} <{s.tag} radius>"),
                                     _float(s.get("length"), f"{where} <{s.tag} length>")])
    elif s.tag == "mesh":
        fn = s.get("filename")
        if not fn:
            raise RobotFileError(f"{where}: <mesh> without filename")
        scale = _vec(s.get("scale"), f"{where} <mesh scale>", default=[1, 1, 1])
        local = mesh_hull(_resolve_mesh(fn, urdf, package_dirs, where), where) * scale
    else:
        raise RobotFileError(f"{where}: unknown geometry <{s.tag}>")
    return p + (local @ Ro.T + po) @ R.T


# ----------------------------------------------------------------------------------------------
# MJCF (compiled by MuJoCo)

def _load_mjcf(path: Path, posture: dict[str, float], keyframe: str | None) -> Description:
    where = str(path)
    try:
        import mujoco
    except ImportError:
        raise RobotFileError(f"{where}: reading MJCF needs MuJoCo: pip install 'anklehip[robot]'") from None
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except Exception as e:      # MuJoCo's compiler errors name the element
        raise RobotFileError(f"{where}: MuJoCo cannot compile it: {e}") from None
    data = mujoco.MjData(model)
    src = "qpos0 (the file's positions, hinge joints at 0)"
    if keyframe is not None:
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) for k in range(model.nkey)]
        if keyframe not in names:
            raise RobotFileError(f"{where}: no <key name={keyframe!r}> (known: {', '.join(n for n in names if n) or 'none'})")
        data.qpos[:] = model.key_qpos[names.index(keyframe)]
        src = f"keyframe {keyframe!r}"
    jnames = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): j for j in range(model.njnt)}
    unknown = set(posture) - set(jnames)
    if unknown:
        raise RobotFileError(f"{where}: the posture names unknown joints: {', '.join(sorted(unknown))}")
    for n, v in posture.items():
        j = jnames[n]
        if int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise RobotFileError(f"{where}: joint {n}: only hinge and slide joints take a posture value")
        data.qpos[model.jnt_qposadr[j]] = v
    if posture:
        src += " + " + ", ".join(f"{k} = {v:g}" for k, v in posture.items())
    mujoco.mj_kinematics(model, data)
    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "revolute", int(mujoco.mjtJoint.mjJNT_SLIDE): "prismatic",
             int(mujoco.mjtJoint.mjJNT_FREE): "free", int(mujoco.mjtJoint.mjJNT_BALL): "ball"}
    bodies: dict[str, Body] = {}
    sole: dict[str, np.ndarray] = {}
    q_used: dict[str, float] = {}
    for b in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
        pid = int(model.body_parentid[b])
        parent = None if pid == 0 else (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, pid) or f"body{pid}")
        joint = None
        nj = int(model.body_jntnum[b])
        if nj > 1:
            raise RobotFileError(f"{where}: body {name}: {nj} joints; one joint per body is supported")
        if nj == 1:
            j = int(model.body_jntadr[b])
            jn = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
            kind = kinds[int(model.jnt_type[j])]
            lo = hi = None
            if model.jnt_limited[j]:
                lo, hi = (float(x) for x in model.jnt_range[j])
            eff = None
            if model.jnt_actfrclimited[j]:
                eff = float(max(abs(model.jnt_actfrcrange[j][0]), abs(model.jnt_actfrcrange[j][1])))
            q = float(data.qpos[model.jnt_qposadr[j]]) if kind in ("revolute", "prismatic") else 0.0
            if kind in ("revolute", "prismatic"):
                q_used[jn] = q
            joint = Joint(jn, kind, np.array(data.xaxis[j]), np.array(data.xanchor[j]), q, lo, hi, eff, None)
        R = np.array(data.ximat[b]).reshape(3, 3)
        I = R @ np.diag(model.body_inertia[b]) @ R.T
        pts = []
        for g in range(int(model.body_geomadr[b]), int(model.body_geomadr[b] + model.body_geomnum[b])) \
                if model.body_geomnum[b] else []:
            if not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue          # a visual geom: no contact
            pts.append(_mj_geom_points(mujoco, model, data, g, where))
        points = np.vstack(pts) if pts else np.zeros((0, 3))
        bodies[name] = Body(name, parent, joint, float(model.body_mass[b]), np.array(data.xipos[b]), I, points,
                            np.array(data.xpos[b]))
        if SOLE_NAME.search(name):
            sole[name] = np.array(data.xpos[b])
    for s in range(model.nsite):
        n = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, s) or ""
        if SOLE_NAME.search(n):
            sole[n] = np.array(data.site_xpos[s])
    ground = None
    gsrc = ""
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == 0 and int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_PLANE):
            n = np.array(data.geom_xmat[g]).reshape(3, 3)[:, 2]
            if n[2] > 1 - 1e-12:
                ground = float(data.geom_xpos[g][2])
                gsrc = f"the world's plane {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or g!r}"
                break
    d = Description(path, "mjcf", bodies, q_used, src, ground, gsrc, sole)
    if any(b.joint is not None and b.joint.kind == "free" for b in bodies.values()):
        d.notes.append("free joint: the posture places the root where the file (or keyframe) puts it")
    return d


def _mj_geom_points(mujoco, model, data, g: int, where: str) -> np.ndarray:
    R = np.array(data.geom_xmat[g]).reshape(3, 3)
    p = np.array(data.geom_xpos[g])
    t, s = int(model.geom_type[g]), model.geom_size[g]
    G = mujoco.mjtGeom
    if t == G.mjGEOM_BOX:
        local = shape_points("box", 2 * s)
    elif t == G.mjGEOM_SPHERE:
        local = shape_points("sphere", [s[0]])
    elif t in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
        local = shape_points("cylinder" if t == G.mjGEOM_CYLINDER else "capsule", [s[0], 2 * s[1]])
    elif t == G.mjGEOM_ELLIPSOID:
        local = shape_points("sphere", [1.0]) * s
    elif t == G.mjGEOM_MESH:
        m = model.geom_dataid[g]
        a, n = model.mesh_vertadr[m], model.mesh_vertnum[m]
        local = np.array(model.mesh_vert[a:a + n], float)    # MuJoCo centres meshes in the geom frame
    else:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or g
        raise RobotFileError(f"{where}: geom {name}: type {t} is not supported as contact geometry")
    return p + local @ R.T
