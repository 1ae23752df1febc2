/* settings.c: everything about a setting that follows from its row in SRV_SETTINGS: defaults,
 * range checks, JSON in and out, the command line. See settings.h. */
#include "server/api/settings.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/api/api_error.h"
#include "server/base/args.h"

_Static_assert(PC_TONEMAP_ACES == 0 && PC_TONEMAP_CLAMP == 1, "SRV_TONEMAP_NAMES order");
_Static_assert(PC_VIEW_FINAL == 0 && PC_VIEW_IRRADIANCE == 1 && PC_VIEW_PROBES == 2,
               "SRV_VIEW_NAMES order");
_Static_assert(PC_GI_OFF == 0 && PC_GI_CLASSIC == 1 && PC_GI_DDGI == 2 && SRV_GI_PATHTRACE == 3,
               "SRV_GI_NAMES order");
_Static_assert(PC_ENV_UNIFORM == 0 && PC_ENV_GRADIENT == 1 && PC_ENV_IMAGE == 2,
               "SRV_SKY_MODE_NAMES order");
_Static_assert(PC_DDGI_VIS_ALL == 0 && PC_DDGI_VIS_PROBES == 1 && PC_DDGI_VIS_OFF == 2,
               "SRV_VISIBILITY_NAMES order");
_Static_assert(SRV_SETTING_COUNT <= 31, "SRV_SET_* bits fit an int enum");

#define BAD(...) (srv_api_fail(e, 400, SRV_ERR_INVALID_FIELD, __VA_ARGS__), false)

/* ---- the table as data ------------------------------------------------------------------ */

#define UNPAREN_(...) __VA_ARGS__
#define UNPAREN(x) UNPAREN_ x
#define COUNT(a) (sizeof(a) / sizeof(a)[0])

#define NAMES_(ID, f, TYPE, json_, flag_, cli_, arg_, min_, max_, def_, scope_, names_, desc_)     \
    static const char *const enum_names_##ID[] = {UNPAREN(names_)};
SRV_SETTINGS(NAMES_)

#define IS_(TYPE, T) (SRV_TYPE_##TYPE == SRV_TYPE_##T)
#define INFO_(ID, f, TYPE, json_, flag_, cli_, arg_, min_, max_, def_, scope_, names_, desc_)      \
    {.bit = SRV_SET_##ID,                                                                          \
     .field = #f,                                                                                  \
     .offset = offsetof(srv_settings, f),                                                          \
     .type = SRV_TYPE_##TYPE,                                                                      \
     .json = json_,                                                                                \
     .flag = flag_,                                                                                \
     .cli = SRV_CLI_##cli_,                                                                        \
     .arg = arg_,                                                                                  \
     .min = IS_(TYPE, ENUM) || IS_(TYPE, BOOL) ? 0 : (min_),                                       \
     .max = IS_(TYPE, ENUM)   ? COUNT(enum_names_##ID) - 1.0                                       \
            : IS_(TYPE, BOOL) ? 1                                                                  \
                              : (max_),                                                            \
     .def = (double)(def_),                                                                        \
     .scope = SRV_SCOPE_##scope_,                                                                  \
     .names = IS_(TYPE, ENUM) ? enum_names_##ID : NULL,                                            \
     .name_count = IS_(TYPE, ENUM) ? (unsigned)COUNT(enum_names_##ID) : 0,                         \
     .desc = desc_},
static const srv_setting_info table[SRV_SETTING_COUNT] = {SRV_SETTINGS(INFO_)};

#define CPU_(ID, value) {SRV_SETTING_INDEX_##ID, (value)},
static const struct {
    unsigned index;
    double value;
} cpu_defaults[] = {SRV_SETTINGS_CPU(CPU_)};

const srv_setting_info *srv_setting_at(unsigned i)
{
    return i < SRV_SETTING_COUNT ? &table[i] : NULL;
}

const srv_setting_info *srv_setting_by_json(const char *json)
{
    for (unsigned i = 0; json && i < SRV_SETTING_COUNT; i++)
        if (strcmp(table[i].json, json) == 0) return &table[i];
    return NULL;
}

const srv_setting_info *srv_setting_by_flag(const char *flag, unsigned cli)
{
    for (unsigned i = 0; flag && i < SRV_SETTING_COUNT; i++)
        if ((table[i].cli & cli) && strcmp(table[i].flag, flag) == 0) return &table[i];
    return NULL;
}

/* ---- values as doubles ------------------------------------------------------------------ */

static int dims(const srv_setting_info *d)
{
    return d->type == SRV_TYPE_FLOAT3 || d->type == SRV_TYPE_UINT3 ? 3 : 1;
}

static bool is_float(const srv_setting_info *d)
{
    return d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
}

static void load(const srv_setting_info *d, const srv_settings *s, double v[3])
{
    const char *p = (const char *)s + d->offset;
    for (int i = 0; i < dims(d); i++) {
        if (d->type == SRV_TYPE_BOOL)
            v[i] = *(const bool *)p;
        else if (is_float(d))
            v[i] = ((const float *)p)[i];
        else
            v[i] = ((const unsigned *)p)[i];
    }
}

/* v must be value_ok for d. */
static void store(const srv_setting_info *d, srv_settings *s, const double v[3])
{
    char *p = (char *)s + d->offset;
    for (int i = 0; i < dims(d); i++) {
        if (d->type == SRV_TYPE_BOOL)
            *(bool *)p = v[i] != 0;
        else if (is_float(d))
            ((float *)p)[i] = (float)v[i];
        else
            ((unsigned *)p)[i] = (unsigned)v[i];
    }
}

/* Whether v is a value of d: finite, integral unless a float, within [min, max] (float
 * settings against the float bounds, so that a stored 0.999f passes as 0.999 did). The one
 * rule beyond ranges: probe_counts are all 0 (fitted) or all at least 1. */
static bool value_ok(const srv_setting_info *d, const double v[3])
{
    bool zero = false, nonzero = false;
    for (int i = 0; i < dims(d); i++) {
        double lo = is_float(d) ? (float)d->min : d->min;
        double hi = is_float(d) ? (float)d->max : d->max;
        if (!isfinite(v[i]) || !(v[i] >= lo && v[i] <= hi)) return false;
        if (!is_float(d) && v[i] != floor(v[i])) return false;
        zero |= v[i] == 0;
        nonzero |= v[i] != 0;
    }
    return d->bit != SRV_SET_PROBE_COUNTS || !(zero && nonzero);
}

/* What value_ok accepts, as the end of "Field 'x' must be ..." or "--x expects ...". */
static void describe(const srv_setting_info *d, bool json, char *buf, size_t len)
{
    const char *list = json ? "an array of 3" : "3 comma-separated";
    size_t n = 0;
    switch (d->type) {
    case SRV_TYPE_UINT:
        snprintf(buf, len, "an integer in %.0f..%.0f", d->min, d->max);
        break;
    case SRV_TYPE_FLOAT: /* the bounds as floats print (0.999f as 0.999) */
        snprintf(buf, len, "a number in [%.7g, %.7g]", d->min, d->max);
        break;
    case SRV_TYPE_FLOAT3:
        snprintf(buf, len, "%s numbers in [%.7g, %.7g]", list, d->min, d->max);
        break;
    case SRV_TYPE_UINT3:
        snprintf(buf, len, "%s integers in %.0f..%.0f%s", list, d->min, d->max,
                 d->bit == SRV_SET_PROBE_COUNTS ? ", all 0 (fitted) or all at least 1" : "");
        break;
    case SRV_TYPE_ENUM:
        n = (size_t)snprintf(buf, len, "one of:");
        for (unsigned i = 0; i < d->name_count && n < len; i++)
            n += (size_t)snprintf(buf + n, len - n, "%s %s", i ? "," : "", d->names[i]);
        break;
    case SRV_TYPE_BOOL:
        snprintf(buf, len, "true or false");
        break;
    }
}

void srv_settings_defaults(srv_settings *s)
{
    memset(s, 0, sizeof *s);
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        double v[3] = {table[i].def, table[i].def, table[i].def};
        store(&table[i], s, v);
    }
}

unsigned srv_settings_scope_mask(int scope)
{
    unsigned mask = 0;
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++)
        if (table[i].scope == scope) mask |= table[i].bit;
    return mask;
}

void srv_settings_adapt_to_cpu(srv_settings *s, unsigned given)
{
    for (size_t i = 0; i < COUNT(cpu_defaults); i++) {
        const srv_setting_info *d = &table[cpu_defaults[i].index];
        double v[3] = {cpu_defaults[i].value, cpu_defaults[i].value, cpu_defaults[i].value};
        if (!(given & d->bit)) store(d, s, v);
    }
}

const char *srv_gi_mode_name(unsigned mode)
{
    return mode < COUNT(enum_names_GI_MODE) ? enum_names_GI_MODE[mode] : "unknown";
}

/* ---- apply ------------------------------------------------------------------------------ */

bool srv_state_settings_apply(srv_settings *s, const srv_settings_patch *p, srv_api_error *e)
{
    srv_settings n = *s;
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = &table[i];
        if (!(p->has & d->bit)) continue;
        double v[3];
        load(d, &p->v, v);
        if (!value_ok(d, v)) {
            char what[160];
            describe(d, true, what, sizeof what);
            return BAD("Field '%s' must be %s.", d->json, what);
        }
        store(d, &n, v);
    }
    if ((uint64_t)n.width * n.height > n.max_pixels)
        return BAD("%ux%u is more than max_pixels (%u).", n.width, n.height, n.max_pixels);
    if (n.view != PC_VIEW_FINAL && n.gi_mode != PC_GI_CLASSIC && n.gi_mode != PC_GI_DDGI)
        return BAD("The irradiance and probes views need gi_mode classic or ddgi.");
    uint64_t probes = (uint64_t)n.probe_counts[0] * n.probe_counts[1] * n.probe_counts[2];
    if (probes > RD_DDGI_MAX_PROBES)
        return BAD("At most %u probes (probe_counts give %llu).", RD_DDGI_MAX_PROBES,
                   (unsigned long long)probes);
    *s = n;
    return true;
}

void srv_settings_to_gi(const srv_settings *s, rd_ddgi_settings *gi)
{
    memset(gi, 0, sizeof *gi);
    gi->mode = s->gi_mode == SRV_GI_PATHTRACE ? PC_GI_OFF : s->gi_mode; /* no probes */
    memcpy(gi->counts, s->probe_counts, sizeof gi->counts);
    gi->spacing[0] = gi->spacing[1] = gi->spacing[2] = s->probe_spacing;
    gi->rays = s->rays_per_probe;
    gi->hysteresis = s->hysteresis;
    gi->has_hysteresis = true;
    gi->visibility = s->visibility_rays;
    gi->relocation = s->probe_relocation != 0; /* "on" */
    gi->path_bounces = s->probe_paths;
    gi->has_path_bounces = true;
}

/* ---- JSON ------------------------------------------------------------------------------- */

/* The JSON value it as d's type, into v (not yet range-checked). */
static bool json_value(const srv_setting_info *d, const cJSON *it, double v[3])
{
    switch (d->type) {
    case SRV_TYPE_UINT:
    case SRV_TYPE_FLOAT:
        if (!cJSON_IsNumber(it)) return false;
        v[0] = it->valuedouble;
        return true;
    case SRV_TYPE_FLOAT3:
    case SRV_TYPE_UINT3: {
        if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != 3) return false;
        int i = 0;
        const cJSON *x;
        cJSON_ArrayForEach(x, it)
        {
            if (!cJSON_IsNumber(x)) return false;
            v[i++] = x->valuedouble;
        }
        return true;
    }
    case SRV_TYPE_ENUM:
        for (unsigned i = 0; cJSON_IsString(it) && i < d->name_count; i++) {
            if (strcmp(it->valuestring, d->names[i]) == 0) {
                v[0] = i;
                return true;
            }
        }
        return false;
    case SRV_TYPE_BOOL:
        if (!cJSON_IsBool(it)) return false;
        v[0] = cJSON_IsTrue(it);
        return true;
    }
    return false;
}

bool srv_json_settings_patch(const cJSON *obj, srv_settings_patch *p, srv_api_error *e)
{
    memset(p, 0, sizeof *p);
    const cJSON *it;
    cJSON_ArrayForEach(it, obj)
    {
        const srv_setting_info *d = srv_setting_by_json(it->string);
        if (!d) return BAD("Unknown settings field '%s'.", it->string);
        if (p->has & d->bit) return BAD("Field '%s' appears more than once.", d->json);
        double v[3];
        if (!json_value(d, it, v) || !value_ok(d, v)) {
            char what[160];
            describe(d, true, what, sizeof what);
            return BAD("Field '%s' must be %s.", d->json, what);
        }
        store(d, &p->v, v);
        p->has |= d->bit;
    }
    return true;
}

cJSON *srv_json_settings(const srv_settings *s)
{
    cJSON *j = cJSON_CreateObject();
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = &table[i];
        double v[3];
        load(d, s, v);
        switch (d->type) {
        case SRV_TYPE_UINT:
            cJSON_AddNumberToObject(j, d->json, v[0]);
            break;
        case SRV_TYPE_FLOAT:
            cJSON_AddNumberToObject(j, d->json, srv_json_float((float)v[0]));
            break;
        case SRV_TYPE_FLOAT3:
        case SRV_TYPE_UINT3: {
            cJSON *a = cJSON_AddArrayToObject(j, d->json);
            for (int k = 0; k < 3; k++)
                cJSON_AddItemToArray(
                    a, cJSON_CreateNumber(is_float(d) ? srv_json_float((float)v[k]) : v[k]));
            break;
        }
        case SRV_TYPE_ENUM:
            cJSON_AddStringToObject(
                j, d->json, d->names[v[0] < d->name_count ? (unsigned)v[0] : (unsigned)d->def]);
            break;
        case SRV_TYPE_BOOL:
            cJSON_AddBoolToObject(j, d->json, v[0] != 0);
            break;
        }
    }
    return j;
}

/* ---- command line ----------------------------------------------------------------------- */

/* A flag's value text as d's type, into v (not yet range-checked). */
static bool cli_value(const srv_setting_info *d, const char *text, double v[3])
{
    if (d->type == SRV_TYPE_ENUM) {
        for (unsigned i = 0; i < d->name_count; i++) {
            if (strcmp(text, d->names[i]) == 0) {
                v[0] = i;
                return true;
            }
        }
        return false;
    }
    const char *p = text;
    for (int i = 0; i < dims(d); i++) {
        char *end = NULL;
        v[i] = strtod(p, &end);
        if (end == p || *end != (i + 1 < dims(d) ? ',' : '\0')) return false;
        p = end + 1;
    }
    return true;
}

bool srv_setting_parse(const char *cmd, const srv_setting_info *d, const char *text,
                       srv_settings *s)
{
    double v[3] = {1, 1, 1}; /* a BOOL flag sets true */
    if (d->type != SRV_TYPE_BOOL && (!cli_value(d, text, v) || !value_ok(d, v))) {
        char what[160];
        describe(d, false, what, sizeof what);
        fprintf(stderr, "%s: %s expects %s, got '%s'\n", cmd, d->flag, what, text);
        return false;
    }
    store(d, s, v);
    return true;
}

int srv_settings_parse_flag(const char *cmd, unsigned cli, int argc, char **argv, int *i,
                            srv_settings *s, unsigned *given)
{
    const srv_setting_info *d = srv_setting_by_flag(argv[*i], cli);
    if (!d) return 0;
    const char *text = "";
    if (d->type != SRV_TYPE_BOOL) {
        text = srv_arg_value(cmd, argc, argv, i);
        if (!text) return -1;
    }
    if (!srv_setting_parse(cmd, d, text, s)) return -1;
    *given |= d->bit;
    return 1;
}

/* The separator of a list of d's values: ';' where a value is itself X,Y,Z. */
static char list_separator(const srv_setting_info *d)
{
    return dims(d) == 3 ? ';' : ',';
}

bool srv_setting_parse_list(const char *cmd, const srv_setting_info *d, const char *text,
                            srv_settings *out, unsigned max, unsigned *n)
{
    char sep = list_separator(d), item[256];
    *n = 0;
    for (const char *p = text;; p++) {
        size_t len = strcspn(p, (char[]){sep, '\0'});
        if (*n == max) {
            fprintf(stderr, "%s: %s takes at most %u value%s, got '%s'\n", cmd, d->flag, max,
                    max == 1 ? "" : "s", text);
            return false;
        }
        if (len >= sizeof item) {
            fprintf(stderr, "%s: %s: a value of '%s' is too long\n", cmd, d->flag, text);
            return false;
        }
        snprintf(item, sizeof item, "%.*s", (int)len, p);
        if (!srv_setting_parse(cmd, d, item, &out[*n])) return false;
        ++*n;
        p += len;
        if (!*p) return true;
    }
}

/* "  HEAD  text", the text wrapped at column WIDTH and indented to column COL. */
static void print_option(FILE *f, const char *head, const char *text)
{
    enum { COL = 25, WIDTH = 96 };
    int col = fprintf(f, "  %-22s ", head);
    if (col > COL) col += fprintf(f, " ");
    bool first = true;
    for (const char *p = text; *p;) {
        while (*p == ' ')
            p++;
        const char *w = p;
        while (*w && *w != ' ')
            w++;
        int wl = (int)(w - p);
        if (wl == 0) break;
        if (!first && col + 1 + wl > WIDTH) {
            fprintf(f, "\n%*s", COL, "");
            col = COL;
        } else if (!first) {
            col += fprintf(f, " ");
        }
        col += fprintf(f, "%.*s", wl, p);
        first = false;
        p = w;
    }
    fputc('\n', f);
}

/* A value of d as the command line writes it. */
static void format_value(const srv_setting_info *d, double x, char *buf, size_t len)
{
    if (d->type == SRV_TYPE_ENUM)
        snprintf(buf, len, "%s", x < d->name_count ? d->names[(unsigned)x] : "?");
    else if (d->type == SRV_TYPE_BOOL)
        snprintf(buf, len, "%s", x != 0 ? "on" : "off");
    else if (dims(d) == 3)
        snprintf(buf, len, "%g,%g,%g", x, x, x);
    else
        snprintf(buf, len, "%g", is_float(d) ? (double)(float)x : x);
}

void srv_setting_print_usage(FILE *f, const srv_setting_info *d, bool list, const char *def)
{
    char head[96], text[400], table_def[48];
    size_t n;
    if (d->type == SRV_TYPE_ENUM) {
        n = (size_t)snprintf(head, sizeof head, "%s ", d->flag);
        for (unsigned k = 0; k < d->name_count && n < sizeof head; k++)
            n += (size_t)snprintf(head + n, sizeof head - n, "%s%s", k ? "|" : "", d->names[k]);
    } else {
        n = (size_t)snprintf(head, sizeof head, "%s%s%s", d->flag, d->arg[0] ? " " : "", d->arg);
    }
    if (list && n < sizeof head)
        snprintf(head + n, sizeof head - n, "[%c%s...]", list_separator(d),
                 d->type == SRV_TYPE_ENUM ? "NAME" : d->arg);
    if (!def) {
        format_value(d, d->def, table_def, sizeof table_def);
        def = table_def;
    }
    snprintf(text, sizeof text, "%s (default %s)", d->desc, def);
    print_option(f, head, text);
}

void srv_settings_print_usage(FILE *f, unsigned cli)
{
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = &table[i];
        if (!(d->cli & cli)) continue;
        char def[96];
        format_value(d, d->def, def, sizeof def);
        for (size_t k = 0; (cli & SRV_CLI_SERVE) && k < COUNT(cpu_defaults); k++) {
            if (cpu_defaults[k].index != i) continue;
            size_t n = strlen(def);
            snprintf(def + n, sizeof def - n, "; ");
            format_value(d, cpu_defaults[k].value, def + n + 2, sizeof def - n - 2);
            n = strlen(def);
            snprintf(def + n, sizeof def - n, " on a CPU device");
        }
        srv_setting_print_usage(f, d, false, def);
    }
}
