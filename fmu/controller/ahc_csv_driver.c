/*
 * ahc_csv_driver — steps the C controller library (ahc) directly on a sensor CSV, with the same
 * sample-grid rule as AnkleHipController.fmu, so tests can compare the FMU with the library
 * bit for bit. No FMI involved.
 *
 *   ahc_csv_driver <in.csv> <out.csv> [name=value ...]
 *
 * in.csv: header row; columns "time", "theta_ankle", "theta_hip", "zmp_x", "fz" (any order, other
 * columns ignored). Row k's sensor values are held over (t_k, t_{k+1}]; the ticks k' >= 1 with
 * t_0 + k' T <= t_{k+1} (+1e-9 T) are executed (the FMU's rule). Parameters: defaults overridden
 * by name=value (ahc_params field names). Before the first tick the outputs follow the FMU's
 * initial-output rule (reference = measured posture at t_0, rates 0, phase 0). out.csv: time and the FMU's output columns, one row per
 * input row except the first (t_1 ... t_{N-1}), values printed with %.17g (exact round trip).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ahc/controller.h"

#define MAXCOLS 64
#define LINE 8192

static int split(char *line, char **f, int max) {
    int n = 0;
    char *p = line;
    while (n < max) {
        f[n++] = p;
        p = strchr(p, ',');
        if (!p) break;
        *p++ = '\0';
    }
    for (int i = 0; i < n; ++i) {
        char *e = f[i] + strlen(f[i]);
        while (e > f[i] && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ' || e[-1] == '"')) *--e = '\0';
        while (*f[i] == ' ' || *f[i] == '"') f[i]++;
    }
    return n;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s <in.csv> <out.csv> [name=value ...]\n", argv[0]);
        return 2;
    }
    ahc_params p;
    ahc_params_default(&p);
    for (int a = 3; a < argc; ++a) {
        char name[128];
        const char *eq = strchr(argv[a], '=');
        if (!eq || (size_t)(eq - argv[a]) >= sizeof name) { fprintf(stderr, "bad override %s\n", argv[a]); return 2; }
        memcpy(name, argv[a], (size_t)(eq - argv[a]));
        name[eq - argv[a]] = '\0';
        const ahc_param_info *info = ahc_param_find(name);
        if (!info) { fprintf(stderr, "unknown parameter %s\n", name); return 2; }
        char *base = (char *)&p + info->offset;
        if (info->is_int) { int v = atoi(eq + 1); memcpy(base, &v, sizeof v); }
        else { double v = strtod(eq + 1, NULL); memcpy(base, &v, sizeof v); }
    }
    ahc_controller c;
    int rc = ahc_init(&c, &p);
    if (rc != AHC_OK) { fprintf(stderr, "ahc_init: %s\n", ahc_error_string(rc)); return 1; }

    FILE *in = fopen(argv[1], "r");
    if (!in) { perror(argv[1]); return 1; }
    FILE *out = fopen(argv[2], "w");
    if (!out) { perror(argv[2]); return 1; }
    static char line[LINE];
    char *f[MAXCOLS];
    if (!fgets(line, sizeof line, in)) { fprintf(stderr, "empty input\n"); return 1; }
    int n = split(line, f, MAXCOLS);
    const char *want[5] = {"time", "theta_ankle", "theta_hip", "zmp_x", "fz"};
    int col[5];
    for (int k = 0; k < 5; ++k) {
        col[k] = -1;
        for (int i = 0; i < n; ++i) if (strcmp(f[i], want[k]) == 0) col[k] = i;
        if (col[k] < 0) { fprintf(stderr, "column %s missing\n", want[k]); return 1; }
    }
    fprintf(out, "time,theta_ankle_ref,theta_hip_ref,dtheta_ankle_ref,dtheta_hip_ref,phase,com_x,com_z,"
                 "disturbance_moment,k_w,com_x_desired,fault\n");
    double row[5], prev[5];
    int have_prev = 0;
    double t0 = 0.0;
    unsigned long long ticks = 0;
    ahc_outputs o;
    memset(&o, 0, sizeof o);
    while (fgets(line, sizeof line, in)) {
        if (line[0] == '\n' || line[0] == '\r' || line[0] == '\0') continue;
        int m = split(line, f, MAXCOLS);
        for (int k = 0; k < 5; ++k) {
            if (col[k] >= m) { fprintf(stderr, "short row\n"); return 1; }
            row[k] = strtod(f[col[k]], NULL);
        }
        if (!have_prev) {
            /* Outputs before the first tick: the FMU's rule (hold the measured posture at t0). */
            double th1 = isfinite(row[1]) ? row[1] : 0.0, th2 = isfinite(row[2]) ? row[2] : 0.0;
            double rx = 0.0, rz = 0.0;
            t0 = row[0];
            ahc_com(&p, th1, th2, &rx, &rz);
            o.theta_ankle_ref = th1;
            o.theta_hip_ref = th2;
            o.com_x = isfinite(rx) ? rx : 0.0;
            o.com_z = isfinite(rz) ? rz : 0.0;
            o.com_x_desired = o.com_x;
        } else {
            ahc_sensors s = {prev[1], prev[2], prev[3], prev[4]};
            double due_d = floor((row[0] - t0) / p.sample_period + 1e-9);
            unsigned long long due = due_d > 0.0 ? (unsigned long long)due_d : 0ull;
            while (ticks < due) { ahc_step(&c, &s, &o); ++ticks; }
            fprintf(out, "%.17g,%.17g,%.17g,%.17g,%.17g,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%u\n", row[0],
                    o.theta_ankle_ref, o.theta_hip_ref, o.dtheta_ankle_ref, o.dtheta_hip_ref, o.phase, o.com_x,
                    o.com_z, o.disturbance_moment, o.k_w, o.com_x_desired, o.fault);
        }
        memcpy(prev, row, sizeof row);
        have_prev = 1;
    }
    fclose(in);
    if (fclose(out) != 0) { perror(argv[2]); return 1; }
    return 0;
}
