#!/usr/bin/env python3
"""Writes the committed seed corpus of the FMI fuzzers (fmu/fuzz/corpus/): call programs in the
input format of fmi_fuzz.cpp that take each FMU through the paths a real importer takes, so the
fuzzer starts from deep states instead of discovering the call protocol byte by byte.

    python3 fmu/fuzz/make_seeds.py            # rewrites fmu/fuzz/corpus/*.bin (not the found ones)

The first byte chooses the decoder (fmi_fuzz.cpp): 0 a shallow program (ShallowProgram: opcodes
in the low 5 bits, bit 7 the second instance), 1 or 3 a deep program through FMI 2.0, 2 through
FMI 3.0 (DeepProgram: an initialization, then operations, mostly steps with plausible inputs), 6
through FMI 3.0 Scheduled Execution where the model has a clock; bit 3 (9, 10, 14) with compact
inputs (a step's inputs in one byte: below 128 all held, below 224 one new, else all new).
"""
from __future__ import annotations

from pathlib import Path

INSTANTIATE, FREE, SETUP, ENTER, EXIT, TERMINATE, RESET = 0, 1, 2, 3, 4, 5, 6
SET_REAL, SET_INT, SET_BOOL, SET_STRING, GET = 7, 8, 9, 10, 11
DO_STEP, STEP_MANY, GET_STATE, SET_STATE, FREE_STATE, SERIALIZE, DESERIALIZE = 12, 13, 14, 15, 16, 17, 18
STATUS, DEBUG_LOGGING, CANCEL, DERIVATIVES, COMMON_PATH = 19, 20, 21, 22, 23
SECOND = 0x80

# Instantiate variant byte (fmi_fuzz.cpp decodes name, GUID, type, resources and callbacks from its
# residues): 10 = every argument valid, logging off; 138 = the same with logging on
OK, OK_LOGGING = 10, 138


def start(slot: int = 0) -> list[int]:
    return [INSTANTIATE | slot, OK_LOGGING, COMMON_PATH | slot, 20]


SEEDS = {
    # the importer's protocol: set-up, initialization, 1 ms steps, terminate
    "protocol": [INSTANTIATE, OK, SETUP, 0, 0, 0, 0, ENTER, EXIT, STEP_MANY, 63, STEP_MANY, 63, TERMINATE, FREE],
    # states: get, serialize, deserialize into the other instance, set, free
    "states": start() + start(SECOND) + [GET_STATE, 0, SERIALIZE, 0, 0, 1, DESERIALIZE | SECOND, 0, 0,
                                         SET_STATE | SECOND, 1, 0, STEP_MANY | SECOND, 10, FREE_STATE, 0, 0],
    # forged blobs: bit flips, truncation, junk, foreign bytes, an overwritten value
    "forged": start() + [GET_STATE, 0, SERIALIZE, 0, 0, 1] +
              [DESERIALIZE, 1, 0, 2, 0x10, 0x00, 3, DESERIALIZE, 2, 0, 0x40, 0x00, DESERIALIZE, 3, 0, 16] + [0xAA] * 16 +
              [DESERIALIZE, 5, 0, 13, 0x40, 0x00],
    # inputs with special values between steps
    "inputs": start() + [SET_REAL, 4, 0, 1, 2, 3, 1, 13, 14, 15, 16, STEP_MANY, 5, SET_REAL, 2, 0, 3, 1, 8, 8,
                         STEP_MANY, 20],
    # steps of odd sizes and at wrong times
    "steps": start() + [DO_STEP, 0, 0, DO_STEP, 0, 13, DO_STEP, 1, 17, 1, DO_STEP, 0, 23, DO_STEP, 0, 24,
                        DO_STEP, 0, 25, DO_STEP, 0, 12],
    # reset and re-initialize, terminate twice, status queries, logging categories
    "lifecycle": start() + [RESET, SETUP, 3, 0, 0, 0, ENTER, EXIT, STEP_MANY, 5, TERMINATE, TERMINATE,
                            STATUS, 0, 99, 0, 1, STATUS, 1, 2, 1, 3, DEBUG_LOGGING, 3, 0, 5, 7, 1, 1,
                            CANCEL, DERIVATIVES, 0, 1],
    # odd instantiation arguments
    "instantiate": [INSTANTIATE, 0, INSTANTIATE, 1, INSTANTIATE, 2, INSTANTIATE, 5, INSTANTIATE, 6,
                    INSTANTIATE, 9, INSTANTIATE, 4, COMMON_PATH, 3],
}


# Deep programs (DeepProgram::run). The initialization reads: logging, number of parameters set
# (its residue mod 6; a byte whose sixth is 1 mod 3 turns DeepProgram::stepping_mode on; then per
# parameter: which, kind, value bytes), start time, stop flag. Operations (op % 20): 0-9 a
# step (size byte, then input bytes), 10-11 a run of 1 ms steps, 12 a parameter change, 13 get a
# state, 14 set one, 15-16 restore into the twin and compare, 17 a forged state, 18 reset and
# initialize, 19 terminate.
STEP, RUN, PARAM, GET, SET, COMPARE, FORGE, RESET, TERMINATE = 0, 10, 12, 13, 14, 15, 17, 18, 19
INIT_DEFAULTS = [0, 0, 0, 1]             # no logging, no parameter set, start 0, no stop time


def steps(n: int, size: int = 0, wiggle: int = 126) -> list[int]:
    """n single steps (size byte: 0 = 1 ms) with inputs near their nominal values."""
    out = []
    for k in range(n):
        out += [STEP, size] + [(wiggle + 7 * k) % 250, 100, 130, 120]
    return out


def compact_steps(n: int, size: int = 0) -> list[int]:
    """n single steps in compact form: the inputs held, every eighth step one input new."""
    out = []
    for k in range(n):
        out += [STEP, size] + ([128 + k % 64, (126 + 7 * k) % 250] if k % 8 == 7 else [k % 128])
    return out


def deep(fmi: int, body: list[int], init: list[int] = INIT_DEFAULTS, scheduled: bool = False,
         compact: bool = False) -> list[int]:
    """scheduled: decoder byte 6 (6 % 4 == 2, bit 2 set): an FMI 3.0 program through Scheduled
    Execution for a model with a clock (the controller), an ordinary FMI 3.0 one for the others.
    compact: bit 3 set, a step's inputs in one byte (compact_steps)."""
    return [(1 if fmi == 2 else 6 if scheduled else 2) | (8 if compact else 0)] + init + body


DEEP = {
    # a long run of plausible steps, then a push, then steps again
    "deep_run": deep(2, steps(60) + [RUN, 31] + [120] * 160 + steps(40)),
    "deep_run_fmi3": deep(3, steps(60) + [RUN, 31] + [120] * 160 + steps(40)),
    # states: got and set back, restored into the twin and compared bit for bit, mid-run
    "deep_states": deep(2, steps(30) + [GET] + steps(20) + [COMPARE, 15, 0] + [120] * 64 + [SET, 0] + steps(20)
                        + [COMPARE, 8, 0] + [130] * 40),
    "deep_states_fmi3": deep(3, steps(30) + [GET] + steps(20) + [COMPARE, 15, 0] + [120] * 64 + [SET, 0]
                             + steps(20)),
    # the same through FMI 3.0 Scheduled Execution (clock activations for steps)
    "deep_run_fmi3_se": deep(3, steps(60) + [RUN, 31] + [120] * 160 + steps(40), scheduled=True),
    "deep_states_fmi3_se": deep(3, steps(30) + [GET] + steps(20) + [COMPARE, 15, 0] + [120] * 64 + [SET, 0]
                                + steps(20), scheduled=True),
    # compact inputs: long runs of steps, restores compared and a forgery among them
    "deep_run_compact": deep(2, compact_steps(120) + [COMPARE, 15, 0, 0, 5, 0, 9, 0] + compact_steps(60)
                             + [FORGE, 0x10, 0x00, 0, 1, 200] + compact_steps(40), compact=True),
    "deep_run_compact_fmi3": deep(3, compact_steps(120) + [COMPARE, 15, 0, 0, 5, 0, 9, 0] + compact_steps(60),
                                  compact=True),
    # forged-but-re-signed states at several places, between steps
    "deep_forged": deep(2, steps(25) + [FORGE, 0x10, 0x00, 0, 1, 200] + steps(5) + [FORGE, 0x80, 0x01, 0, 0, 13]
                        + steps(5) + [FORGE, 0x33, 0x02, 0, 17, 64] + steps(10)),
    # the 3D controller's stepping (the parameter-count byte 6: no parameter set, DeepProgram::stepping_mode
    # on, a step at 0.1 s) in 10 ms steps: a state got in the weight shift or the swing, restores compared
    # and a forgery while the step runs, to its settling
    "deep_stepping": deep(2, compact_steps(40, 7) + [GET] + compact_steps(30, 7) + [COMPARE, 15, 0, 0, 5, 0, 9, 0]
                          + compact_steps(60, 7) + [FORGE, 0x10, 0x00, 0, 1, 200] + compact_steps(40, 7),
                          init=[0, 6, 0, 1], compact=True),
    "deep_stepping_fmi3": deep(3, compact_steps(25, 7) + [COMPARE, 15, 0, 0, 5, 0, 9, 0] + compact_steps(25, 7)
                               + [COMPARE, 15, 0, 0, 5, 0, 9, 0] + compact_steps(100, 7), init=[0, 6, 0, 1],
                               compact=True),
    # parameters at their bounds and outside at initialization, changed while running, reset
    "deep_params": deep(2, steps(20) + [PARAM, 1, 3, 8, 128] + steps(20) + [PARAM, 0, 7, 14, 200] + steps(10)
                        + [RESET, 0, 3, 5, 6, 0, 9, 7, 0, 11, 12, 50, 0, 1] + steps(30) + [TERMINATE] + steps(10),
                        init=[1, 3, 4, 6, 0, 9, 7, 0, 2, 8, 77, 0, 1]),
}


def main() -> None:
    out = Path(__file__).resolve().parent / "corpus"
    out.mkdir(exist_ok=True)
    for name, program in SEEDS.items():   # shallow programs: decoder byte 0
        (out / f"{name}.bin").write_bytes(bytes([0] + [b & 0xFF for b in program]))
    for name, program in DEEP.items():
        (out / f"{name}.bin").write_bytes(bytes(b & 0xFF for b in program))
    print(f"wrote {len(SEEDS) + len(DEEP)} seeds to {out}")


if __name__ == "__main__":
    main()
