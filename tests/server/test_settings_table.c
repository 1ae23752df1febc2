/* The settings table (server/api/settings.h) and what is generated from it: defaults, JSON in and
 * out, range checks, the command line of serve, render and eval (their parsers and their --help,
 * run as the probecast program: parsing only, no daemon, no GPU), scopes; and
 * protocol/openapi.yaml's Settings schema against the table. */
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "server/api/api_json.h"
#include "server/api/settings.h"
#include "test_util.h"

#define ALL_BITS ((1u << SRV_SETTING_COUNT) - 1)

static int dims(const srv_setting_info *d)
{
    return d->type == SRV_TYPE_FLOAT3 || d->type == SRV_TYPE_UINT3 ? 3 : 1;
}

static bool parse(const char *text, srv_settings_patch *p, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_settings_patch(j, p, e);
    cJSON_Delete(j);
    return ok;
}

/* ---- protocol/openapi.yaml, components.schemas.Settings ---------------------------------- */

typedef struct yprop {
    char name[64];
    /* each as the YAML has it (a line holds at most 256 characters) */
    char type[256], items_type[256], min[256], max[256], items_min[256], items_max[256];
    char min_items[256], max_items[256], def[256], enums[256];
} yprop;

/* Line-oriented: the Settings schema's properties at indent 8, their keys at 10, the keys of
 * their items at 12; block scalars (description: |) are skipped. */
static int read_schema(const char *path, yprop *props, int max)
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char line[512];
    int n = 0, state = 0, block = -1; /* state: 0 before, 1 in Settings, 2 in its properties */
    bool in_items = false;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        int ind = (int)strspn(line, " ");
        const char *t = line + ind;
        if (!*t || *t == '#') continue;
        if (block >= 0 && ind > block) continue;
        block = -1;
        if (state == 0) {
            if (ind == 4 && strcmp(t, "Settings:") == 0) state = 1;
            continue;
        }
        if (ind <= 4) break; /* the next schema */
        const char *colon = strchr(t, ':');
        if (!colon) continue;
        char key[64], val[256];
        snprintf(key, sizeof key, "%.*s", (int)(colon - t), t);
        snprintf(val, sizeof val, "%s", colon[1] == ' ' ? colon + 2 : colon + 1);
        if (strcmp(val, "|") == 0 || strcmp(val, ">") == 0) block = ind;
        if (ind == 6) {
            state = strcmp(key, "properties") == 0 ? 2 : 1;
        } else if (state == 2 && ind == 8 && n < max) {
            memset(&props[n], 0, sizeof props[n]);
            snprintf(props[n++].name, sizeof props[0].name, "%s", key);
            in_items = false;
        } else if (state == 2 && ind == 10 && n > 0) {
            yprop *p = &props[n - 1];
            in_items = strcmp(key, "items") == 0;
            if (strcmp(key, "type") == 0) snprintf(p->type, sizeof p->type, "%s", val);
            if (strcmp(key, "minimum") == 0) snprintf(p->min, sizeof p->min, "%s", val);
            if (strcmp(key, "maximum") == 0) snprintf(p->max, sizeof p->max, "%s", val);
            if (strcmp(key, "default") == 0) snprintf(p->def, sizeof p->def, "%s", val);
            if (strcmp(key, "enum") == 0) snprintf(p->enums, sizeof p->enums, "%s", val);
            if (strcmp(key, "minItems") == 0)
                snprintf(p->min_items, sizeof p->min_items, "%s", val);
            if (strcmp(key, "maxItems") == 0)
                snprintf(p->max_items, sizeof p->max_items, "%s", val);
        } else if (state == 2 && ind == 12 && n > 0 && in_items) {
            yprop *p = &props[n - 1];
            if (strcmp(key, "type") == 0) snprintf(p->items_type, sizeof p->items_type, "%s", val);
            if (strcmp(key, "minimum") == 0) snprintf(p->items_min, sizeof p->items_min, "%s", val);
            if (strcmp(key, "maximum") == 0) snprintf(p->items_max, sizeof p->items_max, "%s", val);
        }
    }
    fclose(f);
    return n;
}

/* A YAML number equals the table's (float settings compared as floats). */
static bool same_number(const char *yaml, double want, bool is_float)
{
    char *end = NULL;
    double v = strtod(yaml, &end);
    if (!*yaml || *end) return false;
    return is_float ? (float)v == (float)want : v == want;
}

/* 'x' or "x" to x, in place. */
static void unquote(char *s)
{
    size_t n = strlen(s);
    if (n >= 2 && (s[0] == '\'' || s[0] == '"') && s[n - 1] == s[0]) {
        memmove(s, s + 1, n - 2);
        s[n - 2] = 0;
    }
}

/* "[a, 'b', c]" split into items without quotes; returns the count. */
static int split_list(const char *s, char items[][32], int max)
{
    int n = 0;
    if (*s != '[') return -1;
    s++;
    while (*s && *s != ']' && n < max) {
        while (*s == ' ')
            s++;
        size_t len = strcspn(s, ",]");
        char *it = items[n++];
        snprintf(it, 32, "%.*s", (int)len, s);
        for (size_t k = strlen(it); k > 0 && it[k - 1] == ' '; k--)
            it[k - 1] = 0;
        unquote(it);
        s += len;
        if (*s == ',') s++;
    }
    return n;
}

static void check_property(const srv_setting_info *d, const yprop *p)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    const char *scalar = fl ? "number" : "integer";
    switch (d->type) {
    case SRV_TYPE_UINT:
    case SRV_TYPE_FLOAT:
        CHECKF(strcmp(p->type, scalar) == 0, "%s: type %s", d->json, p->type);
        CHECKF(same_number(p->min, d->min, fl), "%s: minimum '%s', table %g", d->json, p->min,
               d->min);
        CHECKF(same_number(p->max, d->max, fl), "%s: maximum '%s', table %g", d->json, p->max,
               d->max);
        CHECKF(same_number(p->def, d->def, fl), "%s: default '%s', table %g", d->json, p->def,
               d->def);
        break;
    case SRV_TYPE_FLOAT3:
    case SRV_TYPE_UINT3: {
        CHECKF(strcmp(p->type, "array") == 0, "%s: type %s", d->json, p->type);
        CHECKF(strcmp(p->min_items, "3") == 0 && strcmp(p->max_items, "3") == 0,
               "%s: minItems/maxItems '%s'/'%s'", d->json, p->min_items, p->max_items);
        CHECKF(strcmp(p->items_type, scalar) == 0, "%s: items type %s", d->json, p->items_type);
        CHECKF(same_number(p->items_min, d->min, fl), "%s: items minimum '%s', table %g", d->json,
               p->items_min, d->min);
        CHECKF(same_number(p->items_max, d->max, fl), "%s: items maximum '%s', table %g", d->json,
               p->items_max, d->max);
        char items[8][32];
        int n = split_list(p->def, items, 8);
        CHECKF(n == 3, "%s: default '%s' is not 3 items", d->json, p->def);
        for (int i = 0; i < n && i < 3; i++)
            CHECKF(same_number(items[i], d->def, fl), "%s: default '%s', table %g", d->json, p->def,
                   d->def);
        break;
    }
    case SRV_TYPE_ENUM: {
        CHECKF(strcmp(p->type, "string") == 0, "%s: type %s", d->json, p->type);
        char items[16][32];
        int n = split_list(p->enums, items, 16);
        CHECKF(n == (int)d->name_count, "%s: enum '%s' has %d names, the table %u", d->json,
               p->enums, n, d->name_count);
        for (int i = 0; i < n && i < (int)d->name_count; i++)
            CHECKF(strcmp(items[i], d->names[i]) == 0, "%s: enum name %d is '%s', table '%s'",
                   d->json, i, items[i], d->names[i]);
        char def[256];
        snprintf(def, sizeof def, "%s", p->def);
        unquote(def);
        CHECKF(strcmp(def, d->names[(unsigned)d->def]) == 0, "%s: default '%s', table '%s'",
               d->json, def, d->names[(unsigned)d->def]);
        break;
    }
    case SRV_TYPE_BOOL:
        CHECKF(strcmp(p->type, "boolean") == 0, "%s: type %s", d->json, p->type);
        CHECKF(strcmp(p->def, d->def != 0 ? "true" : "false") == 0, "%s: default '%s'", d->json,
               p->def);
        break;
    }
}

static void test_openapi(void)
{
    static yprop props[64];
    int n = read_schema(PROBECAST_SOURCE_DIR "/protocol/openapi.yaml", props, 64);
    CHECKF(n > 0, "no Settings properties read from openapi.yaml (%d)", n);
    bool seen[SRV_SETTING_COUNT] = {false};
    for (int i = 0; i < n; i++) {
        const srv_setting_info *d = srv_setting_by_json(props[i].name);
        CHECKF(d != NULL, "openapi.yaml has setting '%s' that the table lacks", props[i].name);
        if (!d) continue;
        unsigned idx = (unsigned)(d - srv_setting_at(0));
        CHECKF(!seen[idx], "openapi.yaml lists '%s' twice", d->json);
        seen[idx] = true;
        check_property(d, &props[i]);
    }
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++)
        CHECKF(seen[i], "openapi.yaml lacks setting '%s'", srv_setting_at(i)->json);
}

/* ---- the table itself --------------------------------------------------------------------- */

static void test_table(void)
{
    unsigned bits = 0;
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        CHECKF(d->bit == 1u << i, "%s: bit", d->json);
        CHECKF(srv_setting_by_json(d->json) == d, "%s: found by name", d->json);
        CHECKF(d->min <= d->def && d->def <= d->max, "%s: default %g outside [%g, %g]", d->json,
               d->def, d->min, d->max);
        CHECKF(d->desc && d->desc[0], "%s: description", d->json);
        CHECKF(d->type != SRV_TYPE_ENUM || d->name_count > 1, "%s: names", d->json);
        bits |= d->bit;
    }
    CHECK(bits == ALL_BITS && srv_setting_at(SRV_SETTING_COUNT) == NULL);
    /* the bit values other code was written against */
    CHECK(SRV_SET_WIDTH == 1u << 0 && SRV_SET_STILL_DELAY == 1u << 6 && SRV_SET_RAYS == 1u << 14 &&
          SRV_SET_ANIMATE == 1u << 16);

    unsigned world = srv_settings_scope_mask(SRV_SCOPE_WORLD);
    unsigned view = srv_settings_scope_mask(SRV_SCOPE_VIEW);
    CHECK((world | view) == ALL_BITS && (world & view) == 0);
    CHECK((world & SRV_SET_GI_FIELDS) == SRV_SET_GI_FIELDS);
    CHECK(world == (SRV_SET_ENV_FIELDS | SRV_SET_GI_FIELDS | SRV_SET_ANIMATE));
    CHECK(view & SRV_SET_WIDTH && view & SRV_SET_EXPOSURE && view & SRV_SET_VIEW);
    CHECK(srv_settings_scope_mask(0) == 0);

    /* the ranges and defaults the renderer defines, taken by name */
    const srv_setting_info *h = srv_setting_at(SRV_SETTING_INDEX_HYSTERESIS);
    CHECK(h->min == 0 && h->max == RD_DDGI_MAX_HYSTERESIS && h->def == RD_DDGI_DEFAULT_HYSTERESIS);
    const srv_setting_info *r = srv_setting_at(SRV_SETTING_INDEX_RAYS);
    CHECK(r->max == PC_DDGI_MAX_RAYS && r->def == RD_DDGI_DEFAULT_RAYS);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_PROBE_COUNTS)->max == RD_DDGI_MAX_AXIS_PROBES);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_WIDTH)->def == RD_VIEW_DEFAULT_WIDTH);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_HEIGHT)->def == RD_VIEW_DEFAULT_HEIGHT);

    /* a flag for the commands that take it, each flag once */
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        CHECKF(!d->flag == !d->cli && (d->cli & ~(unsigned)SRV_CLI_ALL) == 0, "%s: flag and CLI",
               d->json);
        CHECKF(!d->flag || srv_setting_by_flag(d->flag, d->cli) == d, "%s: found by flag", d->json);
        CHECKF(!d->flag || srv_setting_by_flag(d->flag, SRV_CLI_ALL & ~d->cli) == NULL,
               "%s: only its commands take %s", d->json, d->flag);
    }

    CHECK(strcmp(srv_gi_mode_name(PC_GI_DDGI), "ddgi") == 0);
    CHECK(strcmp(srv_gi_mode_name(SRV_GI_PATHTRACE), "pathtrace") == 0);
    CHECK(strcmp(srv_gi_mode_name(99), "unknown") == 0);
}

static void test_defaults(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    CHECK(s.width == 960 && s.height == 540 && s.max_pixels == 1920 * 1080 && s.max_fps == 30);
    CHECK(s.quality_interactive == 60 && s.quality_still == 90 && s.still_delay_ms == 150);
    CHECK(s.exposure_ev == 0 && s.tonemap == PC_TONEMAP_ACES && s.view == PC_VIEW_FINAL);
    CHECK(s.sky[0] == 0 && s.sky[1] == 0 && s.sky[2] == 0);
    CHECK(s.gi_mode == PC_GI_DDGI && s.probe_counts[0] == 0 && s.probe_counts[2] == 0);
    CHECK(s.probe_spacing == 0 && !s.animate);
    CHECK(s.rays_per_probe == RD_DDGI_DEFAULT_RAYS);
    CHECK(s.hysteresis == RD_DDGI_DEFAULT_HYSTERESIS);

    /* the defaults are a valid patch */
    srv_settings t;
    srv_settings_defaults(&t);
    srv_settings_patch p = {.has = ALL_BITS, .v = s};
    srv_api_error e;
    CHECK(srv_state_settings_apply(&t, &p, &e));

    /* every default as the JSON view gives it */
    cJSON *j = srv_json_settings(&s);
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        const cJSON *it = cJSON_GetObjectItemCaseSensitive(j, d->json);
        CHECKF(it != NULL, "%s in the JSON view", d->json);
        if (!it) continue;
        if (d->type == SRV_TYPE_ENUM)
            CHECKF(cJSON_IsString(it) && strcmp(it->valuestring, d->names[(unsigned)d->def]) == 0,
                   "%s", d->json);
        else if (d->type == SRV_TYPE_BOOL)
            CHECKF(cJSON_IsBool(it) && cJSON_IsTrue(it) == (d->def != 0), "%s", d->json);
        else if (dims(d) == 3)
            CHECKF(cJSON_IsArray(it) && cJSON_GetArraySize(it) == 3 &&
                       cJSON_GetArrayItem(it, 1)->valuedouble == d->def,
                   "%s", d->json);
        else
            CHECKF(cJSON_IsNumber(it) && (float)it->valuedouble == (float)d->def, "%s = %g",
                   d->json, it->valuedouble);
    }
    CHECK(cJSON_GetArraySize(j) == SRV_SETTING_COUNT);
    cJSON_Delete(j);

    /* a CPU device starts smaller where the command line did not choose */
    srv_settings c = s;
    srv_settings_adapt_to_cpu(&c, SRV_SET_WIDTH | SRV_SET_RAYS);
    CHECK(c.width == 960 && c.height == 288 && c.rays_per_probe == RD_DDGI_DEFAULT_RAYS &&
          c.max_fps == 15 && c.quality_still == 90);
}

/* ---- JSON in and out -------------------------------------------------------------------- */

static void test_round_trip(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    s.width = 640, s.height = 360, s.max_pixels = 1 << 20, s.max_fps = 12;
    s.quality_interactive = 33, s.quality_still = 99, s.still_delay_ms = 0;
    s.exposure_ev = -1.5f, s.tonemap = PC_TONEMAP_CLAMP;
    s.sky[0] = 0.25f, s.sky[1] = 0.5f, s.sky[2] = 1000;
    s.view = PC_VIEW_PROBES, s.gi_mode = PC_GI_CLASSIC;
    s.probe_counts[0] = 4, s.probe_counts[1] = 5, s.probe_counts[2] = 6;
    s.probe_spacing = 0.7f, s.rays_per_probe = 1024, s.hysteresis = 0.999f, s.animate = true;

    char *text = srv_json_print_delete(srv_json_settings(&s));
    srv_settings_patch p;
    srv_api_error e;
    CHECKF(parse(text, &p, &e), "%s: %s", text, e.message);
    CHECK(p.has == ALL_BITS);
    srv_settings t;
    srv_settings_defaults(&t);
    CHECKF(srv_state_settings_apply(&t, &p, &e), "%s", e.message);
    char *text2 = srv_json_print_delete(srv_json_settings(&t));
    CHECKF(strcmp(text, text2) == 0, "%s\n  became %s", text, text2);
    CHECK(t.width == 640 && t.max_pixels == 1 << 20 && t.still_delay_ms == 0);
    CHECK(t.exposure_ev == -1.5f && t.tonemap == PC_TONEMAP_CLAMP && t.sky[2] == 1000);
    CHECK(t.view == PC_VIEW_PROBES && t.gi_mode == PC_GI_CLASSIC && t.probe_counts[2] == 6);
    CHECK(t.probe_spacing == 0.7f && t.rays_per_probe == 1024 && t.hysteresis == 0.999f);
    CHECK(t.animate);
    free(text);
    free(text2);

    /* a partial patch names only what it sets */
    CHECK(parse("{\"gi_mode\":\"pathtrace\",\"sky\":[1,2,3]}", &p, &e));
    CHECK(p.has == (SRV_SET_GI_MODE | SRV_SET_SKY) && p.v.gi_mode == SRV_GI_PATHTRACE &&
          p.v.sky[1] == 2);
    CHECK(parse("{}", &p, &e) && p.has == 0);
}

/* hysteresis 0 is a value (no history), not "the default". */
static void test_zero_is_a_value(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    srv_settings_patch p;
    srv_api_error e;
    CHECK(parse("{\"hysteresis\":0,\"exposure\":0}", &p, &e) &&
          p.has == (SRV_SET_HYSTERESIS | SRV_SET_EXPOSURE));
    CHECK(srv_state_settings_apply(&s, &p, &e) && s.hysteresis == 0);
    rd_ddgi_settings gi;
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.hysteresis == 0 && gi.has_hysteresis && gi.rays == RD_DDGI_DEFAULT_RAYS);
    cJSON *j = srv_json_settings(&s);
    const cJSON *h = cJSON_GetObjectItemCaseSensitive(j, "hysteresis");
    CHECK(cJSON_IsNumber(h) && h->valuedouble == 0);
    cJSON_Delete(j);

    srv_settings_defaults(&s);
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.hysteresis == RD_DDGI_DEFAULT_HYSTERESIS && gi.mode == PC_GI_DDGI);
    s.gi_mode = SRV_GI_PATHTRACE;
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.mode == PC_GI_OFF); /* the path tracer uses no probes */
}

/* A JSON body with d just outside its range (an unknown name, a wrong kind of value). */
static void bad_json(const srv_setting_info *d, bool above, char *buf, size_t len)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    double bound = above ? d->max : d->min;
    double eps = fl ? 1e-3 * (1 + fabs(bound)) : 1; /* still beyond it as a float */
    double x = above ? bound + eps : bound - eps;
    switch (d->type) {
    case SRV_TYPE_ENUM:
        snprintf(buf, len, "{\"%s\":\"%s\"}", d->json, above ? "nope" : "");
        break;
    case SRV_TYPE_BOOL:
        snprintf(buf, len, "{\"%s\":%s}", d->json, above ? "1" : "\"true\"");
        break;
    case SRV_TYPE_FLOAT3:
    case SRV_TYPE_UINT3:
        snprintf(buf, len, "{\"%s\":[%.17g,%.17g,%.17g]}", d->json, d->def ? d->def : 1, x,
                 d->def ? d->def : 1);
        break;
    default:
        snprintf(buf, len, "{\"%s\":%.17g}", d->json, x);
    }
}

static void test_rejects(void)
{
    srv_settings_patch p;
    srv_api_error e;
    char body[256];
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        for (int above = 0; above < 2; above++) {
            bad_json(d, above, body, sizeof body);
            e.status = 0;
            bool ok = parse(body, &p, &e);
            CHECKF(!ok && e.status == 400 && strcmp(e.code, SRV_ERR_INVALID_FIELD) == 0 &&
                       strstr(e.message, d->json),
                   "%s accepted or wrong error: %s", body, e.message);
        }
        /* the wrong JSON type */
        snprintf(body, sizeof body, "{\"%s\":%s}", d->json,
                 d->type == SRV_TYPE_ENUM ? "0" : "\"x\"");
        CHECKF(!parse(body, &p, &e) && strstr(e.message, d->json), "%s", body);
        /* a whole number is required where the setting is one */
        if (d->type == SRV_TYPE_UINT) {
            snprintf(body, sizeof body, "{\"%s\":%g}", d->json, d->min + 0.5);
            CHECKF(!parse(body, &p, &e), "%s", body);
        }
        /* given twice */
        srv_settings s;
        srv_settings_defaults(&s);
        cJSON *j = srv_json_settings(&s), *one = cJSON_CreateObject();
        cJSON_AddItemToObject(one, d->json, cJSON_Duplicate(cJSON_GetObjectItem(j, d->json), true));
        cJSON_AddItemToObject(one, d->json, cJSON_Duplicate(cJSON_GetObjectItem(j, d->json), true));
        CHECKF(!srv_json_settings_patch(one, &p, &e) && strstr(e.message, "more than once"),
               "%s twice", d->json);
        cJSON_Delete(one);
        cJSON_Delete(j);

        /* apply checks ranges too (patches built in C), all or nothing */
        if (d->type == SRV_TYPE_BOOL) continue;
        srv_settings before = s;
        srv_settings_patch bad = {.has = d->bit, .v = s};
        char *at = (char *)&bad.v + d->offset;
        for (int k = 0; k < dims(d); k++) {
            if (d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3)
                ((float *)at)[k] = (float)d->max * 1.01f + 1;
            else
                ((unsigned *)at)[k] = (unsigned)d->max + 1;
        }
        CHECKF(!srv_state_settings_apply(&s, &bad, &e) && strstr(e.message, d->json),
               "apply took %s above its maximum", d->json);
        CHECK(memcmp(&s, &before, sizeof s) == 0);
    }
    CHECK(!parse("{\"wdith\":64}", &p, &e) && strstr(e.message, "wdith"));
    CHECK(!parse("{\"probe_counts\":[0,2,2]}", &p, &e) && strstr(e.message, "probe_counts"));
    CHECK(!parse("{\"probe_counts\":[2,2]}", &p, &e));
    CHECK(!parse("{\"sky\":[1,2,\"3\"]}", &p, &e));
    CHECK(!parse("{\"hysteresis\":1}", &p, &e));
    CHECK(parse("{\"hysteresis\":0.999,\"still_delay_ms\":0,\"exposure\":-20}", &p, &e));
    CHECK(parse("{\"probe_counts\":[0,0,0],\"probe_spacing\":0}", &p, &e));

    /* rules between settings */
    srv_settings s;
    srv_settings_defaults(&s);
    srv_settings_patch big = {.has = SRV_SET_WIDTH | SRV_SET_HEIGHT,
                              .v = {.width = 4096, .height = 4096}};
    CHECK(!srv_state_settings_apply(&s, &big, &e) && s.width == 960);
    srv_settings_patch probes = {.has = SRV_SET_VIEW | SRV_SET_GI_MODE,
                                 .v = {.view = PC_VIEW_PROBES, .gi_mode = PC_GI_OFF}};
    CHECK(!srv_state_settings_apply(&s, &probes, &e) && s.view == PC_VIEW_FINAL);
    srv_settings_patch many = {.has = SRV_SET_PROBE_COUNTS, .v = {.probe_counts = {256, 256, 2}}};
    CHECK(!srv_state_settings_apply(&s, &many, &e) && s.probe_counts[0] == 0);
}

/* ---- command line ----------------------------------------------------------------------- */

static int run_flags(char **argv, int argc, srv_settings *s, unsigned *given)
{
    for (int i = 0; i < argc; i++) {
        int r = srv_settings_parse_flag("test", SRV_CLI_SERVE, argc, argv, &i, s, given);
        if (r <= 0) return r;
    }
    return 1;
}

static void test_cli(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    unsigned given = 0;
    char *ok[] = {"--width",
                  "64",
                  "--height",
                  "48",
                  "--probes",
                  "2,3,4",
                  "--gi",
                  "pathtrace",
                  "--hysteresis",
                  "0",
                  "--sky",
                  "1,0.5,0",
                  "--exposure",
                  "-2",
                  "--rays",
                  "16",
                  "--max-fps",
                  "60",
                  "--quality-interactive",
                  "50",
                  "--quality-still",
                  "95",
                  "--probe-spacing",
                  "0.5"};
    int n = (int)(sizeof ok / sizeof ok[0]);
    CHECK(run_flags(ok, n, &s, &given) == 1);
    CHECK(s.width == 64 && s.height == 48 && s.probe_counts[1] == 3 &&
          s.gi_mode == SRV_GI_PATHTRACE && s.hysteresis == 0 && s.sky[1] == 0.5f);
    CHECK(s.exposure_ev == -2 && s.rays_per_probe == 16 && s.max_fps == 60);
    CHECK(s.quality_interactive == 50 && s.quality_still == 95 && s.probe_spacing == 0.5f);
    CHECK(given ==
          (SRV_SET_WIDTH | SRV_SET_HEIGHT | SRV_SET_PROBE_COUNTS | SRV_SET_GI_MODE |
           SRV_SET_HYSTERESIS | SRV_SET_SKY | SRV_SET_EXPOSURE | SRV_SET_RAYS | SRV_SET_MAX_FPS |
           SRV_SET_QUALITY_INTERACTIVE | SRV_SET_QUALITY_STILL | SRV_SET_PROBE_SPACING));

    /* not a setting flag, or not one of this command's: left to the caller */
    char *other[] = {"--token", "x"};
    int i = 0;
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, other, &i, &s, &given) == 0 && i == 0);
    char *render_only[] = {"--tonemap", "clamp"};
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, render_only, &i, &s, &given) == 0);
    CHECK(srv_settings_parse_flag("test", SRV_CLI_RENDER, 2, render_only, &i, &s, &given) == 1 &&
          i == 1 && s.tonemap == PC_TONEMAP_CLAMP);

    fprintf(stderr, "(the messages below are expected)\n");
    const char *bad[][2] = {
        {"--width", "8"},    {"--width", "64.5"},  {"--width", "-64"}, {"--probes", "0,2,2"},
        {"--probes", "2,2"}, {"--gi", "full"},     {"--rays", "0"},    {"--hysteresis", "1"},
        {"--sky", "-1,0,0"}, {"--exposure", "30"}, {"--max-fps", "x"}, {"--sky", "1,2,3,"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        srv_settings t = s;
        unsigned g = 0;
        char *argv[] = {(char *)bad[k][0], (char *)bad[k][1]};
        i = 0;
        CHECKF(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, argv, &i, &t, &g) == -1 &&
                   g == 0 && memcmp(&t, &s, sizeof t) == 0,
               "%s %s accepted", bad[k][0], bad[k][1]);
    }
    char *missing[] = {"--rays"};
    i = 0;
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 1, missing, &i, &s, &given) == -1);

    /* the usage lines: every flag once, defaults from the table */
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    srv_settings_print_usage(f, SRV_CLI_SERVE);
    fclose(f);
    for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
        const srv_setting_info *d = srv_setting_at(k);
        if (!(d->cli & SRV_CLI_SERVE)) continue;
        char head[64];
        snprintf(head, sizeof head, "  %s ", d->flag);
        CHECKF(strstr(text, head) != NULL, "usage lacks %s", d->flag);
    }
    CHECKF(strstr(text, "--hysteresis H") && strstr(text, "(default 0.97)"), "%s", text);
    CHECKF(strstr(text, "(default 256; 64 on a CPU device)"), "%s", text);
    CHECKF(strstr(text, "--gi off|classic|ddgi|pathtrace"), "%s", text);
    CHECKF(!strstr(text, "--tonemap"), "%s", text);
    free(text);
}

/* ---- the commands' flags: every setting of serve, render and eval at its bounds and beyond --- */

static const struct {
    const char *name;
    unsigned cli;
} commands[] = {{"serve", SRV_CLI_SERVE}, {"render", SRV_CLI_RENDER}, {"eval", SRV_CLI_EVAL}};

/* eval takes these as lists (cmd_eval.c, EVAL_SWEEPS) */
#define SWEEPS (SRV_SET_RAYS | SRV_SET_HYSTERESIS | SRV_SET_PROBE_COUNTS)

/* d's value x as the command line writes it (in every component); an ENUM's x beyond its names is
 * a name it lacks. */
static void cli_text(const srv_setting_info *d, double x, char *buf, size_t len)
{
    if (d->type == SRV_TYPE_ENUM)
        snprintf(buf, len, "%s", x >= 0 && x < d->name_count ? d->names[(unsigned)x] : "nope");
    else if (dims(d) == 3)
        snprintf(buf, len, "%.17g,%.17g,%.17g", x, x, x);
    else
        snprintf(buf, len, "%.17g", x);
}

/* Just beyond d's bound (still beyond it as a float). */
static double beyond(const srv_setting_info *d, bool above)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    double bound = above ? d->max : d->min;
    double eps = fl ? 1e-3 * (1 + fabs(bound)) : 1;
    return above ? bound + eps : bound - eps;
}

/* The parsers as the commands call them: srv_settings_parse_flag for one value, and
 * srv_setting_parse_list for eval's sweeps. */
static void test_cli_bounds(void)
{
    for (unsigned c = 0; c < sizeof commands / sizeof commands[0]; c++) {
        for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
            const srv_setting_info *d = srv_setting_at(k);
            if (!(d->cli & commands[c].cli)) continue;
            char lo[96], hi[96], below[96], above[96];
            cli_text(d, d->min, lo, sizeof lo);
            cli_text(d, d->max, hi, sizeof hi);
            cli_text(d, beyond(d, false), below, sizeof below);
            cli_text(d, beyond(d, true), above, sizeof above);
            const char *values[4] = {lo, hi, below, above};
            for (int v = 0; v < 4; v++) {
                srv_settings s, before;
                srv_settings_defaults(&s);
                before = s;
                unsigned given = 0;
                char *argv[] = {(char *)d->flag, (char *)values[v]};
                int i = 0;
                int r = srv_settings_parse_flag(commands[c].name, commands[c].cli, 2, argv, &i,
                                                &s, &given);
                if (v < 2) {
                    CHECKF(r == 1 && given == d->bit, "%s %s %s refused", commands[c].name,
                           d->flag, values[v]);
                    /* the last component, as stored */
                    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
                    const char *m = (const char *)&s + d->offset;
                    double got = fl ? ((const float *)m)[dims(d) - 1]
                                    : ((const unsigned *)m)[dims(d) - 1];
                    double want = v == 0 ? d->min : d->max;
                    CHECKF(fl ? (float)got == (float)want : got == want, "%s %s: stored %g",
                           d->flag, values[v], got);
                } else {
                    CHECKF(r == -1 && given == 0 && memcmp(&s, &before, sizeof s) == 0,
                           "%s %s %s accepted", commands[c].name, d->flag, values[v]);
                }
            }
            /* a list of values, as eval sweeps them */
            if (commands[c].cli != SRV_CLI_EVAL || !(d->bit & SWEEPS)) continue;
            char sep = dims(d) == 3 ? ';' : ',', list[256];
            srv_settings out[8];
            unsigned n = 0;
            snprintf(list, sizeof list, "%s%c%s", lo, sep, hi);
            CHECKF(srv_setting_parse_list("eval", d, list, out, 8, &n) && n == 2, "%s %s refused",
                   d->flag, list);
            for (int v = 2; v < 4; v++) {
                snprintf(list, sizeof list, "%s%c%s", lo, sep, values[v]);
                CHECKF(!srv_setting_parse_list("eval", d, list, out, 8, &n), "%s %s accepted",
                       d->flag, list);
            }
            snprintf(list, sizeof list, "%s%c", lo, sep);
            CHECKF(!srv_setting_parse_list("eval", d, list, out, 8, &n), "%s %s", d->flag, list);
            CHECK(!srv_setting_parse_list("eval", d, "", out, 8, &n));
            CHECK(!srv_setting_parse_list("eval", d, list, out, 1, &n)); /* more than max */
        }
    }
    /* the values of a list, in order */
    srv_settings out[8];
    unsigned n = 0;
    const srv_setting_info *h = srv_setting_by_flag("--hysteresis", SRV_CLI_EVAL);
    CHECK(srv_setting_parse_list("eval", h, "0.85,0,0.999", out, 8, &n) && n == 3 &&
          out[0].hysteresis == 0.85f && out[1].hysteresis == 0 && out[2].hysteresis == 0.999f);
    CHECK(!srv_setting_parse_list("eval", h, "0.5,1", out, 8, &n));
    const srv_setting_info *p = srv_setting_by_flag("--probes", SRV_CLI_EVAL);
    CHECK(srv_setting_parse_list("eval", p, "2,3,4;0,0,0", out, 8, &n) && n == 2 &&
          out[0].probe_counts[2] == 4 && out[1].probe_counts[0] == 0);
    CHECK(!srv_setting_parse_list("eval", p, "2,3,4;0,1,1", out, 8, &n));
}

/* Runs the probecast program with args (NULL-terminated) and stderr to /dev/null; returns its
 * exit status (-1 when it did not exit), and its stdout in *out (caller frees) when out. */
static int run_probecast(const char *const *args, char **out)
{
    const char *argv[16] = {PROBECAST_EXE};
    for (int i = 0; args[i] && i < 14; i++)
        argv[i + 1] = args[i];
    int fd[2];
    if (pipe(fd) != 0) return -1;
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_WRONLY);
        dup2(fd[1], 1);
        dup2(null, 2);
        close(fd[0]);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(fd[1]);
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    char buf[4096];
    ssize_t got;
    while ((got = read(fd[0], buf, sizeof buf)) > 0)
        fwrite(buf, 1, (size_t)got, f);
    fclose(f);
    close(fd[0]);
    int status = 0;
    if (pid < 0 || waitpid(pid, &status, 0) != pid) status = -1;
    if (out)
        *out = text;
    else
        free(text);
    return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* The program itself: each command takes its settings' flags at their bounds and refuses them
 * beyond (the flags come before --help, which then ends the parse with status 0), refuses the
 * flags of settings it does not take, and its --help names every flag it takes. */
static void test_cli_programs(void)
{
    for (unsigned c = 0; c < sizeof commands / sizeof commands[0]; c++) {
        const char *cmd = commands[c].name;
        char *help = NULL;
        const char *args[] = {cmd, "--help", NULL};
        CHECKF(run_probecast(args, &help) == 0 && help, "%s --help", cmd);
        if (!help) continue;
        for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
            const srv_setting_info *d = srv_setting_at(k);
            if (!d->flag) continue;
            bool takes = d->cli & commands[c].cli;
            bool list = commands[c].cli == SRV_CLI_EVAL && (d->bit & SWEEPS);
            char head[64];
            snprintf(head, sizeof head, "\n  %s ", d->flag);
            CHECKF(!strstr(help, head) == !takes, "%s --help %s %s", cmd,
                   takes ? "lacks" : "shows", d->flag);
            char lo[96], hi[96], below[96], above[96], value[200];
            cli_text(d, d->min, lo, sizeof lo);
            cli_text(d, d->max, hi, sizeof hi);
            cli_text(d, beyond(d, false), below, sizeof below);
            cli_text(d, beyond(d, true), above, sizeof above);
            const char *values[4] = {lo, hi, below, above};
            char sep = dims(d) == 3 ? ';' : ',';
            for (int v = 0; v < 4; v++) {
                if (list) /* a list of the lower bound and the value */
                    snprintf(value, sizeof value, "%s%c%s", lo, sep, values[v]);
                else
                    snprintf(value, sizeof value, "%s", values[v]);
                const char *run[] = {cmd, d->flag, value, "--help", NULL};
                int want = takes && v < 2 ? 0 : 2;
                int got = run_probecast(run, NULL);
                CHECKF(got == want, "probecast %s %s %s --help: exit %d, not %d", cmd, d->flag,
                       value, got, want);
                if (!takes) break; /* refused whatever the value */
            }
        }
        free(help);
    }
    /* the help of a sweep shows the list and eval's defaults; render's the table's */
    static const char *const shows[][4] = {
        {"eval", "--hysteresis H[,H...]", "(default 0.85,0.97)", "--probes X,Y,Z[;X,Y,Z...]"},
        {"render", "--hysteresis H ", "(default 0.97)", "--tonemap aces|clamp"},
    };
    for (unsigned c = 0; c < sizeof shows / sizeof shows[0]; c++) {
        char *help = NULL;
        const char *args[] = {shows[c][0], "--help", NULL};
        CHECK(run_probecast(args, &help) == 0 && help);
        for (int k = 1; help && k < 4; k++)
            CHECKF(strstr(help, shows[c][k]) != NULL, "%s --help lacks '%s'", shows[c][0],
                   shows[c][k]);
        free(help);
    }
    /* what the brief of issue 27 asked by hand */
    const char *h15[] = {"render", "--hysteresis", "1.5", "builtin:cornell", NULL};
    CHECK(run_probecast(h15, NULL) == 2);
}

int main(void)
{
    test_table();
    test_defaults();
    test_round_trip();
    test_zero_is_a_value();
    test_rejects();
    test_cli();
    test_cli_bounds();
    test_cli_programs();
    test_openapi();
    return test_finish();
}
