#!/usr/bin/env python3
"""Writes the committed seed corpus of the FMI fuzzers (fmu/fuzz/corpus/): call programs in the
input format of fmi_fuzz.cpp that take each FMU through the paths a real importer takes, so the
fuzzer starts from deep states instead of discovering the call protocol byte by byte.

    python3 fmu/fuzz/make_seeds.py            # rewrites fmu/fuzz/corpus/*.bin

Opcodes (low 5 bits; bit 7 selects the second instance), as decoded by Program::run.
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


def main() -> None:
    out = Path(__file__).resolve().parent / "corpus"
    out.mkdir(exist_ok=True)
    for name, program in SEEDS.items():
        (out / f"{name}.bin").write_bytes(bytes(b & 0xFF for b in program))
    print(f"wrote {len(SEEDS)} seeds to {out}")


if __name__ == "__main__":
    main()
