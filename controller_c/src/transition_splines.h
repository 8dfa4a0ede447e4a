/*
 * transition_splines.h — private: the invariants of the transition's quintics (eqs. 23-24) in a
 * restored state, shared by the sagittal law (controller.c) and the frontal plane (frontal.c).
 * Not installed.
 */
#ifndef AHC_TRANSITION_SPLINES_H
#define AHC_TRANSITION_SPLINES_H

#include <stddef.h>

#include "ahc/controller.h"

/* Both splines are built together over one duration T (on reset and entering phase 1): kw from 0 to
 * 1, the CoM reference rd (named rd_name in messages, e.g. "rxd_spline") from its start (r, v0, 0)
 * to rest. So: rd's start bounded by +-1e9 (its higher coefficients grow as 1/T^5, 1.9e14 at the
 * least legal T: only finite), every coefficient finite and equal to its recomputation from T and
 * the start, both durations T; and k_w 0 in phase 0, 1 in phases 2-3. Returns AHC_OK, or
 * AHC_ERR_INCONSISTENT with a message that names the field. */
int ahc_transition_splines_check(const ahc_quintic *kw, const ahc_quintic *rd, const char *rd_name, double T,
                                 int phase, double k_w, char *msg, size_t msg_size);

#endif
