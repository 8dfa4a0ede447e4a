"""The cross-validation figures of docs/plant3d.md, from the built FMUs (build/fmus or
$ANKLEHIP_FMU_DIR):

- docs/images/plant3d_paper_pushes.png: `paper_five_pushes` on both plants, hip angle and ZMP
  overlaid (cross-check 4), with the per-push peaks printed;
- docs/images/plant3d_step_push.png: a held push 50 % above the sagittal plant's tipping force,
  foot pitch of both plants until the fall (cross-check 3; the numbers are
  tests/test_plant3d_fmu.py::test_step_push_above_tipping_falls_like_the_sagittal_plant's).

Usage: .venv/bin/python scripts/plant3d_figures.py [--out docs/images]
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime  # noqa: E402

from anklehip.running.master import Models, simulate  # noqa: E402
from anklehip.files.paths import PLANT_FMUS, find_fmu, scenarios_dir  # noqa: E402
from anklehip.analysis.summary import summarize_pushes  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402

REPO = Path(__file__).resolve().parent.parent


class Plant:
    """One plant FMU alone, named access, 1 ms steps."""

    def __init__(self, fmu: Path, params: dict, tmp: Path):
        unz = extract(str(fmu), unzipdir=str(tmp / fmu.stem))
        md = read_model_description(unz)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.f = FMU2Slave(guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier,
                           instanceName=fmu.stem)
        self.f.instantiate()
        self.f.setupExperiment(startTime=0.0)
        self.f.enterInitializationMode()
        for k, v in params.items():
            self.f.setReal([self.vr[k]], [v])
        self.f.exitInitializationMode()
        self.t = 0.0

    def set(self, name, v):
        self.f.setReal([self.vr[name]], [v])

    def get(self, name):
        return self.f.getReal([self.vr[name]])[0]

    def step(self) -> bool:
        """False when the plant reports the fall (fmi2Discard)."""
        try:
            self.f.doStep(currentCommunicationPoint=self.t, communicationStepSize=1e-3)
        except Exception:
            return False
        self.t += 1e-3
        return True


def tipping_force(fmu: Path, tmp: Path) -> float:
    """Slow push ramp (1 N/s), joints held: the force at which the heels lift."""
    p = Plant(fmu, {}, tmp)
    while p.t < 30.0:
        p.set("push_force", p.t)
        p.step()
        if p.f.getInteger([p.vr["contact_mode"]])[0] != 0:
            return p.t
    return float("nan")


def step_push(fmu: Path, params: dict, force: float, tmp: Path):
    p = Plant(fmu, params, tmp)
    p.set("theta_ankle_ref", params.get("theta_ankle_init", 0.0))
    t, pitch = [], []
    while p.t < 3.0:
        p.set("push_force", force if p.t >= 0.2 - 1e-9 else 0.0)
        if not p.step():
            return np.array(t), np.array(pitch), p.f.getRealStatus(fmi2LastSuccessfulTime)
        t.append(p.t)
        pitch.append(p.get("foot_pitch"))
    return np.array(t), np.array(pitch), None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "docs" / "images"))
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)

    # cross-check 4: the paper's pushes on both plants
    runs = {}
    for name in ("paper_five_pushes", "paper_five_pushes_3d"):
        sc = load_scenario(scenarios_dir() / f"{name}.toml")
        res = simulate(sc, Models.load(plant_model=sc.plant_model), progress=False)
        runs[sc.plant_model] = (res.data, summarize_pushes(res, sc.push))
    fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for model, style in (("sagittal", dict(color="tab:blue", lw=1.0)), ("3d", dict(color="tab:red", lw=1.0))):
        d = runs[model][0]
        label = "Hoap2Plant (sagittal, CVODE)" if model == "sagittal" else "Hoap2Plant3D (ODE)"
        ax[0].plot(d["time"], np.degrees(d["theta_hip"]), label=label, **style)
        ax[1].plot(d["time"], 1000 * d["zmp_x"], label=label, **style)
    ax[0].set_ylabel("hip angle θ2 [deg]")
    ax[1].set_ylabel("ZMP x [mm]")
    ax[1].set_xlabel("time [s]")
    ax[0].legend(fontsize=8, loc="upper right")
    ax[0].set_title("paper_five_pushes: the unchanged controller FMU on both plants")
    for x in ax:
        x.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "plant3d_paper_pushes.png", dpi=110)
    plt.close(fig)
    for (p3, p2) in zip(runs["3d"][1], runs["sagittal"][1]):
        print(f"push {p3.index + 1}: peak hip {np.degrees(p3.peak_hip):.2f} / {np.degrees(p2.peak_hip):.2f} deg "
              f"({100 * (p3.peak_hip / p2.peak_hip - 1):+.1f} %), peak ZMP {1000 * p3.peak_zmp:.1f} / "
              f"{1000 * p2.peak_zmp:.1f} mm ({100 * (p3.peak_zmp / p2.peak_zmp - 1):+.1f} %)")

    # cross-check 3: a held push above the tipping force (set-up as in the test)
    with tempfile.TemporaryDirectory() as tmpd:
        tmp = Path(tmpd)
        fmu2, fmu3 = find_fmu(PLANT_FMUS["sagittal"]), find_fmu(PLANT_FMUS["3d"])
        p3 = Plant(fmu3, {}, tmp / "a")
        p3.step()
        com_x3, com_z3 = p3.get("com_x"), p3.get("com_z")
        p2 = Plant(fmu2, {}, tmp / "b")
        p2.step()
        lean = float(-np.arcsin((com_x3 - p2.get("com_x")) / com_z3))
        force = 1.5 * tipping_force(fmu2, tmp / "c")
        t3, y3, f3 = step_push(fmu3, {"theta_ankle_init": lean, "kp_knee": 1e4, "kd_knee": 200.0}, force, tmp / "d")
        t2, y2, f2 = step_push(fmu2, {}, force, tmp / "e")
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t2, np.degrees(y2), color="tab:blue", label=f"Hoap2Plant (sagittal): falls at {f2:.3f} s")
    ax.plot(t3, np.degrees(y3), color="tab:red", ls="--", label=f"Hoap2Plant3D (ODE): falls at {f3:.3f} s")
    ax.axvline(0.2, color="0.5", lw=0.8)
    ax.set_xlabel("time [s] (push from 0.2 s)")
    ax.set_ylabel("foot pitch [deg] (+ = on the toes)")
    ax.set_title(f"held push {force:.2f} N (1.5 x the tipping force), joints held")
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "plant3d_step_push.png", dpi=110)
    plt.close(fig)
    print(f"step push {force:.2f} N: fall at {f3:.4f} s (3D) vs {f2:.4f} s (sagittal)")
    for f in ("plant3d_paper_pushes.png", "plant3d_step_push.png"):
        print(out / f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
