/* A program outside this repository's build that uses the installed controller library
 * (tests/test_c_install.py builds it with find_package(ahc) and with pkg-config). It holds the ZMP
 * past the hip-strategy trigger and prints the phase the controller reaches and its references. */
#include <stdio.h>
#include "ahc/controller.h"

int main(void)
{
    ahc_controller ctl;
    ahc_params p;
    ahc_sensors s = {0};
    ahc_outputs o = {0};
    char msg[160];
    int k, seen_transition = 0;

    ahc_params_default(&p);
    if (ahc_params_validate(&p, msg, sizeof msg) != AHC_OK || ahc_init(&ctl, &p) != AHC_OK) {
        fprintf(stderr, "ahc: %s\n", msg);
        return 1;
    }
    s.fz = 70.0;                                 /* standing: the robot's weight [N] */
    for (k = 0; k < 200; ++k) {                  /* 0.2 s at 1 kHz */
        s.zmp_x = k < 50 ? 0.0 : p.zmp_limit_front + 0.005;   /* past the trigger after 50 ms */
        ahc_step(&ctl, &s, &o);
        if (o.phase == AHC_PHASE_ANKLE_TO_HIP) seen_transition = 1;
    }
    printf("ahc %s: phase %d (%s), theta_hip_ref %.6f rad, nominal mass %.4f kg\n",
           seen_transition ? "ok" : "no transition", o.phase, ahc_phase_name(o.phase), o.theta_hip_ref,
           HOAP2_M1 + HOAP2_M2);
    return seen_transition ? 0 : 2;
}
