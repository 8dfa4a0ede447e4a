"""The command line's parser: every command and option, with its help (docs/scenarios.md lists
them). The global options (--fmu-dir) are accepted before and after the command's name."""
from __future__ import annotations

import argparse
import math

from .. import __version__

EXIT_OK, EXIT_FAIL, EXIT_ERROR = 0, 1, 2
FMI_VERSIONS = (2, 3)
FMI3_COMMANDS = ("run", "export", "info")   # the commands that load the FMI 3.0 twins with --fmi 3

CONTROLLER_CONFIG_HELP = ("a named controller configuration (default: the scenario's controller_config or "
                          "'default'; e.g. paper); --set overrides still apply on top")


def _variants_help() -> str:
    from ..running.sweep import VARIANTS_HELP
    return VARIANTS_HELP


def global_options(p: argparse.ArgumentParser, default) -> None:
    """Options every command takes, before or after its name (a command's own parser leaves them
    alone unless given there: default SUPPRESS)."""
    p.add_argument("--fmu-dir", metavar="DIR", default=default,
                   help="folder with the .fmu files (default: $ANKLEHIP_FMU_DIR, else the checkout's build/fmus, "
                        "else the installed package's; `anklehip where` shows which)")
    p.add_argument("--fmi", type=int, choices=FMI_VERSIONS, default=2 if default is None else default,
                   help="FMI version of the FMUs: 2 (default) or 3, the FMI 3.0 twins in <fmu dir>/fmi3/ "
                        f"(commands: {', '.join(FMI3_COMMANDS)}; the FMPy engine)")


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (the usage is in --help); subcommands inherit it."""

    def error(self, message: str):
        self.exit(EXIT_ERROR, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _number(ge: float | None = None, gt: float | None = None, integer: bool = False, le: float | None = None):
    """An argparse type: a finite number (an integer with `integer`), >= ge, > gt, <= le; the error
    names the value (argparse adds the option)."""
    what = "an integer" if integer else "a finite number"
    what += f" >= {ge:g}" if ge is not None else f" > {gt:g}" if gt is not None else ""
    what += f" and <= {le:g}" if le is not None else ""

    def convert(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
        if (not math.isfinite(v) or (ge is not None and v < ge) or (gt is not None and not v > gt)
                or (le is not None and v > le)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return v
    return convert


FINITE, NON_NEGATIVE, POSITIVE = _number(), _number(ge=0.0), _number(gt=0.0)


def command(sub, name: str, **kw) -> argparse.ArgumentParser:
    """A command's parser; it takes the global options too (anklehip run X --fmu-dir D)."""
    s = sub.add_parser(name, **kw)
    global_options(s, argparse.SUPPRESS)
    return s


def build_parser() -> argparse.ArgumentParser:
    from ..files.info import CAUSALITIES
    from ..files.scenario import MAX_STEPS
    p = _Parser(prog="anklehip", description="Ankle/hip balance control FMUs: closed-loop "
                                "scenarios, step tests, comparison, plots, sweeps, FMU interfaces.")
    global_options(p, None)
    p.add_argument("--version", action="version", version=f"anklehip {__version__}",
                   help="print the package's version and exit")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND",
                           help="what to do; `anklehip COMMAND --help` lists its options")

    def no_progress(s, what: str):
        s.add_argument("--no-progress", action="store_true",
                       help=f"no progress bars ({what}) on stderr; there are none when stderr is not a terminal")

    s = command(sub, "list", help="list the scenarios (a table: plant, stop time, push, what is expected, reference)")
    s.set_defaults(fn="list")

    s = command(sub, "where", help="where the scenarios, step-test cases, FMUs and native tools are taken from "
                                     "(a checkout, the environment or the installed package)")
    s.set_defaults(fn="where")

    s = command(sub, "info", help="an FMU's interface: model, platforms, default experiment, log categories, "
                                    "parameters, inputs and outputs with units, start values and ranges")
    s.add_argument("fmu", metavar="FMU",
                   help="a .fmu file or extracted FMU folder, or a model name (e.g. AnkleHipController) looked "
                        "up like every FMU (--fmu-dir, $ANKLEHIP_FMU_DIR, the checkout, the package; `anklehip where`)")
    s.add_argument("--json", action="store_true",
                   help="print the same content as JSON on stdout instead of the tables")
    s.add_argument("--causality", action="append", choices=CAUSALITIES, metavar="CAUSALITY",
                   help="only the variables of this causality (repeatable; one of " + ", ".join(CAUSALITIES)
                        + "; default: parameters, calculated/structural parameters, inputs, outputs)")
    s.add_argument("--name", action="append", metavar="PATTERN",
                   help="only variables whose name contains PATTERN, or matches it as a glob with * ? [ ] "
                        "(case-insensitive; repeatable: any of them)")
    s.set_defaults(fn="info")

    def anim_opts(s):
        s.add_argument("--fps", type=POSITIVE, default=20.0,
                       help="animation frames per second (default %(default)g)")
        s.add_argument("--speed", type=POSITIVE, default=1.0,
                       help="simulated seconds per second of animation (default %(default)g)")
        s.add_argument("--anim-start", type=FINITE, metavar="T0",
                       help="animation start time [s] (default: the result's first time)")
        s.add_argument("--anim-stop", type=FINITE, metavar="T1",
                       help="animation stop time [s] (default: the result's last time)")

    s = command(sub, "run", help="run a scenario (CSV, summary, optional plots and animation)")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/<scenario>)")
    s.add_argument("--plots", action="store_true", help="write the overview, Fig. 4 and Fig. 5 PNGs")
    s.add_argument("--animate", action="store_true", help="write a stick-figure GIF")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override, e.g. controller.Ka=30 or plant.h_push=0.3 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    s.add_argument("--fault", action="append", metavar="NAME=VALUE",
                   help="inject a fault on top of the scenario's [faults] (repeatable), e.g. zmp_noise=0.002 "
                        "drop_rate=0.1 delay_steps=2 mass_mismatch=-0.2; the keys: docs/scenarios.md")
    s.add_argument("--plant", choices=("sagittal", "3d"),
                   help="the plant model (default: the scenario's plant_model, else sagittal)")
    s.add_argument("--controller-model", choices=("sagittal", "3d"),
                   help="the controller: sagittal (the paper's) or 3d (with the frontal plane; needs --plant 3d); "
                        "default: the scenario's controller_model, else sagittal")
    s.add_argument("--robot", metavar="ROBOT",
                   help="run on this robot: a robot file (anklehip robot lump) or a name in robots/; both FMUs' "
                        "parameters from it, gains scaled, pushes and times in the robot's units (docs/your-robot.md)")
    s.add_argument("--stop-time", type=FINITE, metavar="T",
                   help="stop at this time [s] instead of the scenario's stop_time (no outcome or reference "
                        f"checks): > 0, a whole number of the scenario's steps, at most {MAX_STEPS} steps")
    no_progress(s, "simulated time, figures, GIF frames")
    s.add_argument("--engine", choices=("fmpy", "native"), default="fmpy",
                   help="the closed-loop master (default %(default)s): fmpy, or native (the same loop in C++, "
                        "bit-identical results, several times faster; no sensor faults or transition pushes)")
    s.add_argument("--no-compare", action="store_true", help="skip the comparison with the reference CSV")
    s.add_argument("--record-steptest", metavar="DIR", help="also write the controller's step-test case into DIR")
    anim_opts(s)
    s.set_defaults(fn="run")

    s = command(sub, "plot", help="plot a results CSV")
    s.add_argument("csv", metavar="CSV",
                   help="a result CSV (time in the first column), e.g. results/<scenario>/<scenario>.csv; the "
                        "standard figures need theta_ankle, theta_hip, zmp_x, com_x, else an overview of every column")
    s.add_argument("--out", metavar="DIR", help="output folder (default: the CSV's folder)")
    s.add_argument("--animate", action="store_true",
                   help="also write a stick-figure GIF <name>.gif (body sizes: the plant FMU's defaults)")
    no_progress(s, "figures, GIF frames")
    anim_opts(s)
    s.set_defaults(fn="plot")

    s = command(sub, "compare", help="compare a result CSV with a reference CSV (FMI cross-check band)")
    s.add_argument("result", help="the result CSV to check (time in the first column)")
    s.add_argument("reference", help="the reference CSV, e.g. scenarios/reference/<scenario>.csv")
    s.add_argument("--columns", metavar="A,B,...", help="comma-separated signals (default: all reference columns)")
    s.add_argument("--num", type=_number(ge=2, integer=True),
                   help="band samples (validate_signal num; default: max(1000, reference rows))")
    s.add_argument("--dx", type=_number(ge=1, integer=True), default=20,
                   help="band horizontal half-width in samples (default %(default)s)")
    s.add_argument("--dy", type=NON_NEGATIVE, default=0.1,
                   help="band vertical half-width relative to the signal's range (default %(default)g)")
    s.add_argument("--abs-tol", type=NON_NEGATIVE,
                   help="stricter tube: absolute tolerance, in the signal's unit (default: none)")
    s.add_argument("--rel-tol", type=NON_NEGATIVE,
                   help="stricter tube: tolerance relative to |reference| (default: none)")
    s.add_argument("--band-floor", type=NON_NEGATIVE,
                   help="minimum band half-height, in the signal's unit, for nearly constant signals (default: none)")
    s.add_argument("--t-start", type=FINITE, metavar="T0",
                   help="compare from this time [s] on (default: the reference's start)")
    s.add_argument("--t-stop", type=FINITE, metavar="T1",
                   help="compare up to this time [s] (default: the reference's end)")
    s.add_argument("--allow-partial", action="store_true", help="do not fail when the result covers less time")
    s.add_argument("--plot", metavar="PNG", help="always write a plot of reference, band/tube, result and failing "
                   "samples: of the failed signals, or of every signal when all pass")
    s.add_argument("--json", metavar="FILE", help="write the report as JSON")
    s.add_argument("--failed-only", action="store_true",
                   help="list only the failed signals (default: every compared signal)")
    no_progress(s, "reading, signals")
    s.set_defaults(fn="compare")

    s = command(sub, "steptest", help="step the controller FMU on recorded inputs and compare (HIL style)")
    s.add_argument("cases", nargs="+", metavar="CASE",
                   help="case folder(s) with <Model>_in.csv, _ref.csv, _ref.opt, or the names of shipped cases "
                        "(`anklehip where` shows where they are)")
    s.add_argument("--fmu", help="controller FMU (default: AnkleHipController.fmu in the FMU folder)")
    s.add_argument("--out", metavar="DIR", help="write <DIR>/<case>/AnkleHipController_out.csv, realtime.json and the "
                   "--plot there (default: no output files; with --plot results/steptest)")
    s.add_argument("--realtime", action="store_true", help="pace the steps in wall-clock time (absolute deadlines)")
    s.add_argument("--native", action="store_true",
                   help="use the native anklehip_rt_step (fmu/rt_runner): paced with --realtime, else as fast as possible")
    s.add_argument("--native-args", nargs=argparse.REMAINDER, metavar="ARG",
                   help="extra arguments for anklehip_rt_step: everything after this option (put it last)")
    s.add_argument("--spin-us", type=NON_NEGATIVE, default=0.0, metavar="US",
                   help="with --realtime, Python runner only: busy-wait the last US microseconds before a deadline "
                        "(default %(default)g)")
    s.add_argument("--histogram", metavar="PNG", help="plot execution time and lateness histograms (with several "
                   "cases one file per case: <stem>_<case>.png beside PNG)")
    s.add_argument("--fail-on-miss", action="store_true", help="with --realtime: a case with a deadline miss fails "
                   "(exit 1), for both runners")
    tol = "(default: the case's steptest.toml [compare]{})"
    s.add_argument("--abs-tol", type=NON_NEGATIVE,
                   help="tube: absolute tolerance, in the signal's unit " + tol.format(""))
    s.add_argument("--rel-tol", type=NON_NEGATIVE,
                   help="tube: tolerance relative to |reference| " + tol.format(""))
    s.add_argument("--dx", type=_number(ge=1, integer=True),
                   help="band horizontal half-width in samples " + tol.format(", else 20"))
    s.add_argument("--dy", type=NON_NEGATIVE,
                   help="band vertical half-width relative to the signal's range " + tol.format(", else 0.1"))
    s.add_argument("--no-compare", action="store_true", help="only step the FMU, do not compare with _ref.csv")
    s.add_argument("--plot", action="store_true",
                   help="plot the failed signals: <out>/<case>/failed_signals.png (never into the case folder)")
    s.add_argument("--failed-only", action="store_true",
                   help="list only the failed signals (default: every compared signal)")
    s.set_defaults(fn="steptest")

    s = command(sub, "record", help="run a scenario and write the controller's step-test case")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("out_pos", nargs="?", metavar="OUT", help="case folder to write (the same as --out)")
    s.add_argument("--out", metavar="DIR", help="case folder to write (default: results/steptests/<scenario>)")
    s.add_argument("--stop-time", type=FINITE, metavar="T",
                   help="record up to this time [s] instead of the scenario's stop_time: > 0, a whole number of "
                        f"the scenario's steps, at most {MAX_STEPS} steps")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override, e.g. controller.Ka=30 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    no_progress(s, "simulated time")
    s.set_defaults(fn="record")

    s = command(sub, "sweep", help="a sweep file (scenarios/sweeps/), or a scenario's peak push force x controller "
                                     "variants, on Dask -> a table of outcomes")
    s.add_argument("scenario", help="a sweep file (name in scenarios/sweeps/ or path), or a scenario with --forces")
    s.add_argument("--forces", metavar="GRID",
                   help="with a scenario: peak forces [N], start:stop:step (inclusive) or a,b,c")
    s.add_argument("--variant", action="append", metavar="VARIANT",
                   help="repeatable: " + _variants_help() + " (default: one variant, default)")
    s.add_argument("--workers", type=_number(ge=1, integer=True), default=2, metavar="N",
                   help="processes of the local Dask cluster (default %(default)s; not used with --scheduler)")
    s.add_argument("--engine", choices=("fmpy", "native"),
                   help="the closed-loop master of each run (default: native when it is built, else fmpy)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (e.g. tcp://host:8786; default: "
                        "$DASK_SCHEDULER_ADDRESS, else a local cluster of --workers processes)")
    s.add_argument("--worker-timeout", type=_number(gt=0), default=120.0, metavar="S",
                   help="with a scheduler that has no worker: how long to wait for one before giving up "
                        "(default %(default)g s)")
    s.add_argument("--restart", action="store_true",
                   help="discard the points an earlier (interrupted) run of this sweep left in --out")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/sweep_<name>); a rerun into the "
                                                "same folder skips the points already done")
    s.set_defaults(fn="sweep")

    s = command(sub, "robustness", help="each fault (docs/scenarios.md) swept over its levels on a scenario "
                                          "-> the largest level that still completes every push cycle (Dask)")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("--study", action="append", metavar="NAME",
                   help="only this study (a fault key or a study label; repeatable; default: all)")
    s.add_argument("--grid", action="append", metavar="KEY=GRID",
                   help="levels of a fault key instead of its default grid: start:stop:step or a,b,c (repeatable)")
    s.add_argument("--workers", type=_number(ge=1, integer=True), default=2, metavar="N",
                   help="processes of the local Dask cluster (default %(default)s; not used with --scheduler)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (default: $DASK_SCHEDULER_ADDRESS, else a local cluster)")
    s.add_argument("--worker-timeout", type=_number(gt=0), default=120.0, metavar="S",
                   help="with a scheduler that has no worker: how long to wait for one before giving up "
                        "(default %(default)g s)")
    s.add_argument("--restart", action="store_true", help="discard the points an earlier run left in --out")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/robustness_<scenario>); a rerun "
                                                "into the same folder skips the points already done")
    s.set_defaults(fn="robustness")

    s = command(sub, "soak", help="one pair of FMU instances for a long time under seeded random pushes: "
                                    "posture drift, memory growth, solver statistics (docs/reliability.md)")
    s.add_argument("--duration", type=_number(gt=0, le=86400), default=3600.0, metavar="S",
                   help="simulated seconds, > 0 and <= 86400 (default %(default)g)")
    s.add_argument("--seed", type=_number(ge=0, integer=True), default=1,
                   help="seed of the push schedule, an integer >= 0 (default %(default)s)")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/soak)")
    no_progress(s, "simulated time")
    s.set_defaults(fn="soak")

    s = command(sub, "export", help="the closed loop of a scenario as an SSP file or as one container FMU")
    s.add_argument("kind", choices=("ssp", "container"),
                   help="ssp: an SSP file (System Structure and Parameterization) with both FMUs; "
                        "container: one co-simulation FMU holding both")
    s.add_argument("scenario", help="scenario name or path; its controller configuration and parameter overrides "
                                    "go into the artefact")
    s.add_argument("--out", metavar="FILE", help="output file (default: results/<scenario>/<scenario>.ssp or .fmu)")
    s.add_argument("--plant", choices=("sagittal", "3d"), help="the plant model (default: the scenario's)")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override written into the artefact, e.g. controller.Ka=30 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    s.add_argument("--libcosim", action="store_true",
                   help="ssp: no system-level push input (libcosim rejects it); drive plant.push_force instead")
    s.set_defaults(fn="export")

    s = command(sub, "regen-references", help="re-run the scenarios and rewrite their reference CSVs and the "
                                                "step-test cases (only those that change), or --check them")
    s.add_argument("names", nargs="*", metavar="NAME",
                   help="only these scenarios (default: every scenario with a [reference] table, and the "
                        "step-test cases)")
    s.add_argument("--force", action="store_true", help="write even if the expected outcome is not met")
    s.add_argument("--no-steptests", action="store_true",
                   help="do not re-record the step-test cases under tests/steptests/")
    s.add_argument("--out", metavar="DIR",
                   help="write into DIR/reference/<name>.csv and DIR/steptests/<case>/ instead of the files themselves "
                        "(default: the checkout's scenarios/reference and tests/steptests; results/references "
                        "for an installed package)")
    s.add_argument("--check", action="store_true",
                   help="write nothing: report which files would change and the largest difference in each "
                        "(exit 1 if one would)")
    no_progress(s, "simulated time")
    s.set_defaults(fn="regen")
    from ..robot.cli import register as register_robot     # anklehip robot lump|check|scale
    register_robot(sub)
    return p
