/*
 * param_rows.h — private helpers shared by the parameter tables of the frontal and stepping layers
 * (ahc_param_info rows over a struct of doubles and ints): look a row up, read a field, check
 * every field against its row's range, and write an error message. Not installed.
 */
#ifndef AHC_PARAM_ROWS_H
#define AHC_PARAM_ROWS_H

#include <math.h>
#include <string.h>

#include "ahc/controller.h"
#include "fail_message.h"


/* The field row e describes in the struct at base, as a double. */
static double ahc_rows_value(const void *base, const ahc_param_info *e)
{
    const char *p = (const char *)base + e->offset;
    if (e->is_int) {
        int v;
        memcpy(&v, p, sizeof v);
        return (double)v;
    } else {
        double v;
        memcpy(&v, p, sizeof v);
        return v;
    }
}

/* The row named name, or NULL. */
static const ahc_param_info *ahc_rows_find(const ahc_param_info *t, size_t n, const char *name)
{
    size_t i;
    if (!name) return NULL;
    for (i = 0; i < n; ++i)
        if (strcmp(t[i].name, name) == 0) return &t[i];
    return NULL;
}

/* Every field finite and within its row's range: AHC_OK, or the first offence named in msg. */
static int ahc_rows_check(const ahc_param_info *t, size_t n, const void *base, char *msg, size_t msg_size)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        const ahc_param_info *e = &t[i];
        const double v = ahc_rows_value(base, e);
        if (!isfinite(v)) return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "%s = %g must be finite", e->name, v);
        if (v < e->min)
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "%s = %.6g must be >= %.6g", e->name, v, e->min);
        if (v > e->max)
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "%s = %.6g must be <= %.6g", e->name, v, e->max);
    }
    return AHC_OK;
}

#endif /* AHC_PARAM_ROWS_H */
