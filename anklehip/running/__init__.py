"""Running FMUs: loading them (fmu), the closed-loop master on FMPy (master) or in C++ (native),
faults, whole scenario runs (run), step tests, sweeps and robustness studies on Dask, the soak."""
