/*
 * test_params — establishes the parameter interface:
 *  - the defaults (and the "paper" configuration) validate and equal the HOAP-2 numbers of
 *    hoap2/nominal.h and the SI gains of docs/controller.md §3; the paper configuration differs only in
 *    the ZMP limits (45 mm);
 *  - the metadata table lists every field of ahc_params exactly once, with offsets equal to
 *    offsetof and correct int flags (copying all rows through the table reproduces the struct
 *    byte for byte);
 *  - every row's range is enforced by ahc_params_validate, and messages name field and value;
 *  - cross-field checks (ZMP limit outside the foot, unstable sample period, band order, ...).
 */
#include <stdlib.h>

#include "ahc_test.h"
#include "ahc/frontal.h"

static int contains(const char *hay, const char *needle) { return strstr(hay, needle) != NULL; }

static void set_field(ahc_params *p, const ahc_param_info *e, double v)
{
    char *base = (char *)p + e->offset;
    if (e->is_int) {
        int iv = (int)v;
        memcpy(base, &iv, sizeof iv);
    } else {
        memcpy(base, &v, sizeof v);
    }
}

static double get_field(const ahc_params *p, const ahc_param_info *e)
{
    const char *base = (const char *)p + e->offset;
    if (e->is_int) {
        int iv;
        memcpy(&iv, base, sizeof iv);
        return iv;
    } else {
        double v;
        memcpy(&v, base, sizeof v);
        return v;
    }
}

int main(void)
{
    ahc_params p, q, paper;
    char msg[256];
    size_t count = 0, i, j;
    const ahc_param_info *t = ahc_param_table(&count);
    int rc;

    ahc_params_default(&p);
    rc = ahc_params_validate(&p, msg, sizeof msg);
    CHECK(rc == AHC_OK, "defaults validate: %s", msg);
    CHECK(p.m1 == HOAP2_M1 && p.m2 == HOAP2_M2 && p.l1 == HOAP2_L1 && p.lg1 == HOAP2_LG1 &&
              p.lg2 == HOAP2_LG2 && p.I1 == HOAP2_I1 && p.I2 == HOAP2_I2 &&
              p.feet_mass == HOAP2_FEET_MASS && p.toe_x == HOAP2_TOE_X && p.heel_x == HOAP2_HEEL_X,
          "model defaults from hoap2/nominal.h");
    CHECK(p.Ka == 40.0 && p.Ca == 10.0 && p.Kh == 4.0 && p.Ch == 1.0 && p.Kpr == 100.0 && p.Kp_theta == 15.0,
          "SI gains");
    CHECK(p.sample_period == 0.001 && p.hip_strategy_enabled == 1, "timing / mode");
    CHECK_NEAR(HOAP2_TOTAL_MASS, 7.1599, 1e-4, "total mass (sum of the Webots proto's body masses)");

    ahc_params_paper(&paper);
    CHECK(ahc_params_validate(&paper, msg, sizeof msg) == AHC_OK, "paper validates: %s", msg);
    CHECK(paper.zmp_limit_front == 0.045, "paper p_lim = 45 mm");
    q = paper;
    q.zmp_limit_front = p.zmp_limit_front;
    q.zmp_limit_back = p.zmp_limit_back;
    CHECK(paper.T_ah == 1.0, "paper T_ah = 1 s");
    q.T_ah = p.T_ah;
    CHECK(memcmp(&q, &p, sizeof p) == 0, "paper differs only in the ZMP limits and T_ah");

    /* named configurations: "default" first, each validates, names unique, lookup by name */
    {
        size_t i, j, nc = ahc_config_count();
        ahc_params named;
        CHECK(nc >= 2 && strcmp(ahc_config_name(0), "default") == 0, "config 0 is default");
        CHECK(ahc_config_name(nc) == NULL && ahc_config_description(nc) == NULL, "NULL past the end");
        for (i = 0; i < nc; ++i) {
            CHECK(ahc_params_named(&named, ahc_config_name(i)) == AHC_OK, "config %zu found", i);
            CHECK(ahc_params_validate(&named, msg, sizeof msg) == AHC_OK, "config %s validates: %s",
                  ahc_config_name(i), msg);
            CHECK(strlen(ahc_config_description(i)) > 10, "config %s described", ahc_config_name(i));
            for (j = 0; j < i; ++j)
                CHECK(strcmp(ahc_config_name(i), ahc_config_name(j)) != 0, "unique name %s", ahc_config_name(i));
        }
        CHECK(ahc_params_named(&named, "default") == AHC_OK && memcmp(&named, &p, sizeof p) == 0,
              "default = ahc_params_default");
        CHECK(ahc_params_named(&named, "paper") == AHC_OK && memcmp(&named, &paper, sizeof p) == 0,
              "paper = ahc_params_paper");
        /* omnidirectional: the default with the sagittal pendulum lean and T_ah 1 s, nothing else
         * (docs/controller.md section 4.7); its frontal part is the frontal defaults */
        CHECK(ahc_params_named(&named, "omnidirectional") == AHC_OK, "omnidirectional found");
        CHECK(named.lean_enabled == 1 && named.lean_law == AHC_LEAN_PENDULUM && named.lean_tau == 0.03 &&
                  named.lean_margin == 0.0325 && named.T_ah == 1.0,
              "omnidirectional: pendulum lean, lean_tau 30 ms, lean_margin 32.5 mm, T_ah 1 s");
        q = named;
        q.lean_enabled = p.lean_enabled;
        q.lean_law = p.lean_law;
        q.lean_tau = p.lean_tau;
        q.lean_margin = p.lean_margin;
        q.T_ah = p.T_ah;
        CHECK(memcmp(&q, &p, sizeof p) == 0, "omnidirectional differs from the default only there");
        {
            ahc_frontal_params fo, fd;
            ahc_frontal_params_default(&fd);
            CHECK(ahc_frontal_params_named(&fo, "omnidirectional") == AHC_OK && memcmp(&fo, &fd, sizeof fd) == 0,
                  "omnidirectional's frontal part is the frontal defaults");
        }
        memset(&named, 0xff, sizeof named);
        CHECK(ahc_params_named(&named, "Paper") == AHC_ERR_UNKNOWN_NAME && memcmp(&named, &p, sizeof p) == 0,
              "unknown name (case matters) -> error, defaults filled");
        CHECK(ahc_params_named(&named, NULL) == AHC_ERR_UNKNOWN_NAME, "NULL name -> error");
        CHECK(strcmp(ahc_error_string(AHC_ERR_UNKNOWN_NAME), "unknown configuration name") == 0, "error string");
    }

    /* table covers the struct */
    CHECK(count >= 40, "table has %zu rows", count);
    {
        ahc_params copy;
        unsigned char covered[sizeof(ahc_params)];
        size_t covered_bytes = 0;
        memset(covered, 0, sizeof covered);
        memset(&copy, 0, sizeof copy);
        memset(&q, 0, sizeof q);
        ahc_params_default(&q); /* q has zero padding (memset inside) */
        for (i = 0; i < count; ++i) {
            const size_t sz = t[i].is_int ? sizeof(int) : sizeof(double);
            CHECK(t[i].offset + sz <= sizeof(ahc_params), "offset in range");
            for (j = 0; j < sz; ++j) {
                CHECK(!covered[t[i].offset + j], "row %s overlaps another row", t[i].name);
                covered[t[i].offset + j] = 1;
            }
            set_field(&copy, &t[i], get_field(&q, &t[i]));
            CHECK(ahc_param_find(t[i].name) == &t[i], "find %s", t[i].name);
            CHECK(t[i].description && strlen(t[i].description) > 5, "%s has a description", t[i].name);
            CHECK(t[i].unit != NULL, "%s has a unit string", t[i].name);
            CHECK(get_field(&q, &t[i]) >= t[i].min && get_field(&q, &t[i]) <= t[i].max,
                  "default of %s within [min, max]", t[i].name);
        }
        for (j = 0; j < sizeof covered; ++j) covered_bytes += covered[j];
        /* every non-padding byte is covered: fill-pattern test detects an unlisted field */
        CHECK(memcmp(&copy, &q, sizeof q) == 0, "table copy reproduces the defaults");
        {
            ahc_params pat, pat_copy;
            memset(&pat, 0x3C, sizeof pat);
            memset(&pat_copy, 0, sizeof pat_copy);
            for (i = 0; i < count; ++i)
                memcpy((char *)&pat_copy + t[i].offset, (char *)&pat + t[i].offset,
                       t[i].is_int ? sizeof(int) : sizeof(double));
            /* uncovered bytes may only be padding: there must be fewer than one field's worth
             * between consecutive rows (alignment padding after an int is 4 bytes) */
            for (j = 0; j + 8 <= sizeof covered; ++j) {
                size_t k, gap = 0;
                for (k = j; k < j + 8; ++k) gap += !covered[k];
                CHECK(gap < 8, "8 uncovered bytes at offset %zu: a field missing from the table", j);
            }
        }
        {   /* at most 4 bytes of padding after each int field */
            size_t n_int = 0;
            for (i = 0; i < count; ++i) n_int += (size_t)t[i].is_int;
            CHECK(covered_bytes >= sizeof(ahc_params) - 4 * n_int, "covered %zu of %zu bytes", covered_bytes,
                  sizeof(ahc_params));
        }
        CHECK(ahc_param_find("hip_strategy_enabled")->is_int && ahc_param_find("feet_offset_mode")->is_int &&
                  ahc_param_find("kinematics_source")->is_int && !ahc_param_find("Ka")->is_int,
              "int flags");
        CHECK(ahc_param_find("Ka")->offset == offsetof(ahc_params, Ka) &&
                  ahc_param_find("sample_period")->offset == offsetof(ahc_params, sample_period),
              "offsets");
        CHECK(ahc_param_find("nonexistent") == NULL, "unknown name");
    }

    /* every row's range is closed (min and max themselves are accepted by the row check) and
     * enforced, the message names field and value */
    for (i = 0; i < count; ++i) {
        double bad[3];
        int nb = 0, k;
        if (t[i].min > -1e300) bad[nb++] = t[i].is_int ? t[i].min - 1.0 : nextafter(t[i].min, -INFINITY);
        if (t[i].max < 1e300) bad[nb++] = t[i].max + 1.0;
        if (!t[i].is_int) bad[nb++] = NAN;
        for (k = 0; k < nb; ++k) {
            char name_eq[96];
            q = p;
            set_field(&q, &t[i], bad[k]);
            rc = ahc_params_validate(&q, msg, sizeof msg);
            snprintf(name_eq, sizeof name_eq, "%s = ", t[i].name);
            CHECK(rc != AHC_OK, "%s = %g accepted", t[i].name, bad[k]);
            CHECK(strncmp(msg, name_eq, strlen(name_eq)) == 0, "message names the field: '%s' for %s", msg,
                  t[i].name);
        }
    }

    /* specific messages: one field set to a bad value, the code and a message naming it */
    {
        static const struct {
            const char *field;
            double value;
            int rc;
            const char *needle[2];
            const char *what;
        } cases[] = {
            { "zmp_limit_back", -0.05, AHC_ERR_INCONSISTENT, { "zmp_limit_back = -0.05", "heel at -0.0375" }, "zmp back" },
            { "Ca", -3, AHC_ERR_RANGE, { "Ca = -3", "" }, "negative gain" },
            { "sample_period", 0, AHC_ERR_RANGE, { "sample_period = 0", "" }, "sample period" },
            /* audit: a denormal period made fmi2DoStep run ~1e9 ticks */
            { "sample_period", 2.2e-310, AHC_ERR_RANGE, { "sample_period = 2.2e-310 must be >= 1e-05", "" }, "denormal period" },
            { "sample_period", 0.2, AHC_ERR_RANGE, { "sample_period = 0.2", "" }, "period beyond 100 ms" },
            { "sample_period", 0.05, AHC_ERR_INCONSISTENT, { "sample_period = 0.05", "" }, "unstable period" },
            { "fz_max", 5.0, AHC_ERR_INCONSISTENT, { "fz_lifted = 10 must be < fz_max = 5", "" }, "fz_max" },
            { "Ka", INFINITY, AHC_ERR_NONFINITE, { "Ka = inf", "" }, "inf" },
            { "hip_strategy_enabled", 2, AHC_ERR_RANGE, { "hip_strategy_enabled = 2", "" }, "int range" },
            { "hip_min", 0.5, AHC_ERR_RANGE, { "hip_min = 0.5", "" }, "hip_min" }, /* violates hip_min <= 0 */
            { "lg1", 0.3, AHC_ERR_INCONSISTENT, { "lg1 = 0.3", "" }, "lg1 > l1" },
        };
        size_t c;
        q = p;
        q.m1 = -1;
        rc = ahc_params_validate(&q, msg, sizeof msg);
        CHECK(rc == AHC_ERR_RANGE && strcmp(msg, "m1 = -1 must be >= 0.01") == 0, "m1 message: %s", msg);
        q = p;
        q.zmp_limit_front = 0.07;
        rc = ahc_params_validate(&q, msg, sizeof msg);
        CHECK(rc == AHC_ERR_INCONSISTENT &&
                  strcmp(msg, "zmp_limit_front = 0.07 lies outside the foot (toe at 0.0575)") == 0,
              "zmp front message: %s", msg);
        for (c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
            const ahc_param_info *e = NULL;
            for (i = 0; i < count; ++i)
                if (strcmp(t[i].name, cases[c].field) == 0) e = &t[i];
            CHECK(e != NULL, "%s is in the parameter table", cases[c].field);
            if (!e) continue;
            q = p;
            set_field(&q, e, cases[c].value);
            rc = ahc_params_validate(&q, msg, sizeof msg);
            CHECK(rc == cases[c].rc && contains(msg, cases[c].needle[0]) && contains(msg, cases[c].needle[1]),
                  "%s message: %s", cases[c].what, msg);
        }
    }
    /* ahc_update_params: validated, state kept */
    {
        ahc_controller c;
        ahc_sensors s = { 0.0, 0.0, 0.01, 70.0 };
        ahc_outputs o;
        int n;
        unsigned long long tick;
        ahc_params r = p;
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        for (n = 0; n < 100; ++n) ahc_step(&c, &s, &o);
        tick = c.tick;
        r.Ka = 50.0;
        r.zmp_filter_tau = 0.01;
        CHECK(ahc_update_params(&c, &r) == AHC_OK && c.p.Ka == 50.0 && c.tick == tick, "update keeps state");
        CHECK_NEAR(c.zmp_alpha, 1.0 - exp(-0.1), 1e-15, "derived constants recomputed");
        r.m1 = -1.0;
        CHECK(ahc_update_params(&c, &r) == AHC_ERR_RANGE && c.p.m1 == p.m1 && c.p.Ka == 50.0,
              "bad update rejected, old params kept");
    }
    CHECK(ahc_params_validate(NULL, msg, sizeof msg) == AHC_ERR_NULL, "NULL");
    CHECK(ahc_params_validate(&q, NULL, 0) == AHC_ERR_INCONSISTENT, "NULL msg buffer allowed");
    {
        char tiny[8];
        ahc_params_validate(&q, tiny, sizeof tiny);
        CHECK(strlen(tiny) == 7, "message truncated safely");
    }
    TEST_MAIN_END();
}
